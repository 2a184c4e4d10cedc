// rtuscope_bench_frame: framing + CRC alone, no pairing, decoding or output. Reads the
// whole input into memory first so that only the framer (and, for a capture, the capture
// parser) is timed.
//
//   rtuscope_bench_frame FILE [raw|capture|scan|lean|crc] [REPEAT]
//
// `scan` times no framer but what its core costs by itself: a raw dump walked by the
// standard rules' lengths, both readings' CRCs checked at each position, with no record
// built, no length search and no timing. It shows how far the framer's other work (and
// this way of finding frames) is from a speed goal.
//
// `lean` times the leanest framer of that kind, as a framer that hands frames on in
// batches would be: lengths from a table made from the standard rules, one CRC pass for
// both readings, an 8-byte record per frame (and per byte of none) into an array; no
// timing, no length search, no choice by the request/answer order. The batch design would
// do more than this, so its speed bounds what such a redesign could reach.
//
// `crc` times less still, the floor of any framer that checks every CRC: the CRC of each
// frame of a raw dump alone, one per frame, where the frames lie told beforehand (by an
// untimed framer run). What it takes of a frame's time budget is not left for finding
// the frame and building its record.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "framing/crc.hpp"
#include "framing/framer.hpp"
#include "framing/functions.hpp"
#include "input/sources.hpp"

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

// The lengths a batch framer of the leanest kind reads from a table: per function code,
// each reading's length is `base` plus, when `count_at` is not 0, the byte at that offset
// (a byte count); base 0: no such reading. Codes of another shape (a sub-function, a
// searched length) are not `simple` and count as no frame.
struct LeanLengths {
    std::array<std::array<std::uint8_t, 256>, 2> base{};  // [0] request, [1] answer
    std::array<std::array<std::uint8_t, 256>, 2> count_at{};
    std::array<bool, 256> simple{};
};

// The table, from the standard rules themselves (not written out again here): each code
// is asked once with zero bytes, then with a 1 at each offset a count can be at; a
// reading whose length grows by exactly 1 there counts the byte at that offset.
LeanLengths lean_lengths() {
    const rtuscope::ProtocolRules& rules = rtuscope::standard_rules();
    LeanLengths table;
    std::array<std::uint8_t, rtuscope::kMaxAdu> head{};
    for (unsigned code = 0; code < 256; ++code) {
        head.fill(0);
        head[1] = static_cast<std::uint8_t>(code);
        const rtuscope::FrameLengths zero = rules.frame_lengths(head);
        bool simple = true;
        for (const rtuscope::Role role : {rtuscope::Role::request, rtuscope::Role::response}) {
            const rtuscope::FrameLength& length = zero.of(role);
            const std::size_t r = role == rtuscope::Role::response ? 1 : 0;
            if (length.kind == rtuscope::FrameLength::Kind::none) continue;
            if (length.kind != rtuscope::FrameLength::Kind::fixed || length.bytes > 255) {
                simple = false;
                continue;
            }
            table.base[r][code] = static_cast<std::uint8_t>(length.bytes);
            for (std::size_t offset = 2; offset < 12; ++offset) {
                head[offset] = 1;
                const rtuscope::FrameLength one = rules.frame_lengths(head).of(role);
                head[offset] = 0;
                if (one.kind != rtuscope::FrameLength::Kind::fixed) {
                    simple = false;
                } else if (one.bytes == length.bytes + 1) {
                    table.count_at[r][code] = static_cast<std::uint8_t>(offset);
                } else if (one.bytes != length.bytes) {
                    simple = false;
                }
            }
        }
        table.simple[code] = simple && (table.base[0][code] != 0 || table.base[1][code] != 0);
    }
    return table;
}

// Where a batch framer hands a frame (or a byte of no frame) on: 8 bytes, no copy.
struct LeanRecord {
    std::uint32_t at = 0;
    std::uint16_t length = 0;
    bool frame = false;
};

// The leanest framer of this kind, as a batch framer would be: at each position both
// readings' lengths from the table and their CRCs in one pass (the shorter's CRC is where
// the longer's begins), the shorter that checks is a frame; a compact record for each
// frame and for each byte of none, written to `out` (reserved beforehand). No timing, no
// length search, no choice by the request/answer order: less than the framer must do, so
// its speed bounds what any framer that checks each frame's CRC in turn reaches here.
std::uint64_t lean_scan(std::span<const std::uint8_t> bytes, const LeanLengths& table,
                        std::vector<LeanRecord>& out) {
    std::uint64_t frames = 0;
    std::size_t at = 0;
    out.clear();
    // A length from the table is at most 255 + 255 (no kMaxAdu cap: a longer one fails
    // its CRC but for one time in 65536): stopping that far before the end, none needs
    // checking against it.
    constexpr std::size_t kLongest = 2 * 255;
    while (at + kLongest <= bytes.size()) {
        const std::uint8_t* p = bytes.data() + at;
        const std::uint8_t code = p[1];
        std::size_t length = 0;
        if (table.simple[code]) {
            // Reading r's length (0 for none): its base, plus its count byte if it has one.
            auto length_of = [&](std::size_t r) -> std::size_t {
                const std::uint8_t count_at = table.count_at[r][code];
                return table.base[r][code] + (count_at != 0 ? p[count_at] : 0U);
            };
            const std::size_t request = length_of(0);
            const std::size_t answer = length_of(1);
            const std::size_t shorter = table.base[0][code] == 0   ? answer
                                        : table.base[1][code] == 0 ? request
                                                                   : std::min(request, answer);
            const std::size_t longer = std::max(request, answer);
            // Over a frame and its CRC the CRC is 0.
            const std::uint16_t crc = rtuscope::crc16_modbus(bytes.subspan(at, shorter));
            if (crc == 0) {
                length = shorter;
            } else if (longer != shorter &&
                       rtuscope::crc16_modbus_update(
                           crc, bytes.subspan(at + shorter, longer - shorter)) == 0) {
                length = longer;
            }
        }
        out.push_back({static_cast<std::uint32_t>(at),
                       static_cast<std::uint16_t>(length != 0 ? length : 1), length != 0});
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
    app.add_option("file", path, "raw dump (raw, scan, lean, crc) or native capture (capture)")
        ->required()
        ->check(CLI::ExistingFile);
    app.add_option("mode", mode, "raw, capture, scan, lean or crc (see bench/frame_tool.cpp)")
        ->capture_default_str()
        ->check(CLI::IsMember({"raw", "capture", "scan", "lean", "crc"}));
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
            content.size(), spans.size(), ok, best,
            static_cast<double>(content.size()) / best / 1e6,
            best * 1e9 / static_cast<double>(spans.size()));
        return 0;
    }
    if (mode == "lean") {
        const LeanLengths table = lean_lengths();
        std::vector<LeanRecord> records;
        records.reserve(bytes.size());
        std::uint64_t frames = 0;
        const double best = best_time(repeat, [&] { frames = lean_scan(bytes, table, records); });
        // Garbage may hold no frame: then there is no time a frame to give.
        const auto per_frame =
            frames == 0 ? std::string("no frames")
                        : fmt::format("{:.1f} ns/frame", best * 1e9 / static_cast<double>(frames));
        fmt::print("lean {} bytes, {} frames ({} compact records): {:.4f} s, {:.1f} MB/s, {}\n",
                   content.size(), frames, records.size(), best,
                   static_cast<double>(content.size()) / best / 1e6, per_frame);
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
