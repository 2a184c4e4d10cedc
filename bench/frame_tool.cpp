// rtuscope_bench_frame: framing + CRC alone, no pairing, decoding or output. Reads the
// whole input into memory first so that only the framer (and, for a capture, the capture
// parser) is timed.
//
//   rtuscope_bench_frame FILE [raw|capture|scan|crc] [REPEAT]
//
// `scan` times no framer but what its core costs by itself: a raw dump walked by the
// standard rules' lengths, both readings' CRCs checked at each position, with no record
// built, no length search and no timing. It shows how far the framer's other work (and
// this way of finding frames) is from a speed goal.
//
// `crc` times less still, the floor of any framer that checks every CRC: the CRC of each
// frame of a raw dump alone, one per frame, where the frames lie told beforehand (by an
// untimed framer run). What it takes of a frame's time budget is not left for finding
// the frame and building its record.
#include <fmt/format.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "rtuscope/crc.hpp"
#include "rtuscope/framer.hpp"
#include "rtuscope/protocol_rules.hpp"
#include "rtuscope/sources.hpp"

namespace {

// The frames a bare boundary scan finds: at each position the shorter reading whose
// length the standard rules give and whose CRC checks is a frame; otherwise one byte on.
std::uint64_t boundary_scan(std::span<const std::uint8_t> bytes) {
    const rtuscope::ProtocolRules& rules = rtuscope::standard_rules();
    std::uint64_t frames = 0;
    std::size_t at = 0;
    while (at + rtuscope::kMinAdu <= bytes.size()) {
        const auto head = bytes.subspan(at, std::min(bytes.size() - at, rtuscope::kMaxAdu));
        std::size_t length = 0;
        for (const rtuscope::Role role : {rtuscope::Role::request, rtuscope::Role::response}) {
            const rtuscope::FrameLength fits = rules.frame_lengths(head).of(role);
            if (fits.kind != rtuscope::FrameLength::Kind::fixed || fits.bytes < rtuscope::kMinAdu ||
                fits.bytes > head.size()) {
                continue;
            }
            if (rtuscope::check_crc(head.first(fits.bytes)).status == rtuscope::CrcStatus::ok &&
                (length == 0 || fits.bytes < length)) {
                length = fits.bytes;
            }
        }
        frames += length != 0;
        at += length != 0 ? length : 1;
    }
    return frames;
}

// Every chunk of `source` through `framer`, then the end.
void frame_all(rtuscope::ChunkSource& source, rtuscope::Framer& framer) {
    rtuscope::Chunk chunk;
    for (;;) {
        auto more = source.next(chunk);
        if (!more.ok() || !*more) break;
        framer.push(chunk);
    }
    framer.finish();
}

// Where each frame (valid or not) of a raw dump lies, by the framer: offset and length.
std::vector<std::pair<std::size_t, std::size_t>> frame_spans(const std::string& content,
                                                             const std::string& name) {
    std::vector<std::pair<std::size_t, std::size_t>> spans;
    auto source = rtuscope::source_from_memory(content, name, rtuscope::InputFormat::raw);
    if (!source) return spans;
    std::size_t offset = 0;
    rtuscope::Framer framer({}, [&](const rtuscope::Frame& f) {
        if (f.cls != rtuscope::RecordClass::noise) spans.emplace_back(offset, f.bytes.size());
        offset += f.bytes.size();
    });
    frame_all(**source, framer);
    return spans;
}

// Seconds `run` takes.
template <class Run>
double seconds_of(Run run) {
    const auto t0 = std::chrono::steady_clock::now();
    run();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Best of `repeat` timings of `run`, in seconds.
template <class Run>
double best_time(int repeat, Run run) {
    double best = 1e300;
    for (int r = 0; r < repeat; ++r) best = std::min(best, seconds_of(run));
    return best;
}

}  // namespace

int main(int argc, char** argv) {
    std::string path;
    std::string mode = "raw";
    int repeat = 1;
    CLI::App app{"rtuscope_bench_frame: framing + CRC alone, the input read into memory first"};
    app.add_option("file", path, "raw dump (raw, scan, crc) or native capture (capture)")
        ->required()
        ->check(CLI::ExistingFile);
    app.add_option("mode", mode, "raw, capture, scan or crc (see bench/frame_tool.cpp)")
        ->capture_default_str()
        ->check(CLI::IsMember({"raw", "capture", "scan", "crc"}));
    app.add_option("repeat", repeat, "runs to take the best of")
        ->capture_default_str()
        ->check(CLI::Range(1, 1000));
    CLI11_PARSE(app, argc, argv);

    std::string content;
    std::error_code error;
    const auto size = std::filesystem::file_size(path, error);
    std::ifstream in(path, std::ios::binary);
    if (!error) content.resize(size);
    if (error || !in.read(content.data(), static_cast<std::streamsize>(content.size()))) {
        fmt::print(stderr, "rtuscope_bench_frame: cannot read {}: {}\n", path,
                   error ? error.message() : "read error");
        return 1;
    }
    if (content.empty()) {
        fmt::print(stderr, "rtuscope_bench_frame: {} is empty: nothing to time\n", path);
        return 1;
    }
    const auto bytes =
        std::span(reinterpret_cast<const std::uint8_t*>(content.data()), content.size());
    if (mode == "crc") {
        const auto spans = frame_spans(content, path);
        if (spans.empty()) {
            fmt::print(stderr, "rtuscope_bench_frame: no frames in {}: no CRCs to time\n", path);
            return 1;
        }
        std::uint64_t ok = 0;
        const double best = best_time(repeat, [&] {
            ok = 0;
            for (const auto& [offset, length] : spans) {
                ok += length >= 3 && rtuscope::crc16_modbus(bytes.subspan(offset, length)) == 0;
            }
        });
        fmt::print(
            "crc {} bytes, {} frames' CRCs alone ({} ok): {:.4f} s, {:.1f} MB/s, {:.1f} ns/frame\n",
            content.size(), spans.size(), ok, best, static_cast<double>(content.size()) / best / 1e6,
            best * 1e9 / static_cast<double>(spans.size()));
        return 0;
    }
    if (mode == "scan") {
        std::uint64_t frames = 0;
        const double best = best_time(repeat, [&] { frames = boundary_scan(bytes); });
        fmt::print(
            "scan {} bytes, {} frames (no records): {:.3f} s, {:.1f} MB/s, {:.2f} M frames/s\n",
            content.size(), frames, best, static_cast<double>(content.size()) / best / 1e6,
            static_cast<double>(frames) / best / 1e6);
        return 0;
    }
    const auto format =
        mode == "capture" ? rtuscope::InputFormat::capture : rtuscope::InputFormat::raw;

    double best = 1e300;
    std::uint64_t frames = 0;
    std::uint64_t bad = 0;
    for (int r = 0; r < repeat; ++r) {
        // The copy into the source is not timed.
        auto source = rtuscope::source_from_memory(content, path, format);
        if (!source) {
            fmt::print(stderr, "{}\n", source.error().message);
            return 1;
        }
        frames = 0;
        bad = 0;
        rtuscope::FramerOptions options;
        options.line = (*source)->info().line.value_or(rtuscope::LineSettings{});
        rtuscope::Framer framer(options, [&](const rtuscope::Frame& f) {
            frames += f.cls == rtuscope::RecordClass::frame;
            bad += f.cls == rtuscope::RecordClass::invalid;
        });
        best = std::min(best, seconds_of([&] { frame_all(**source, framer); }));
    }
    fmt::print("{} {} bytes, {} frames ok, {} invalid: {:.3f} s, {:.1f} MB/s, {:.2f} M frames/s\n",
               mode, content.size(), frames, bad, best,
               static_cast<double>(content.size()) / best / 1e6,
               static_cast<double>(frames + bad) / best / 1e6);
    return 0;
}
