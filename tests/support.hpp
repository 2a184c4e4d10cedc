// Helpers shared by the unit tests: temporary files, frames with their CRC and as a raw
// dump, chunks with timing, and a framer + pairing harness that collects what comes out.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <initializer_list>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "framing/crc.hpp"
#include "framing/framer.hpp"
#include "input/chunk.hpp"
#include "pairing/transactions.hpp"
#include "pipeline.hpp"
#include "profiles/bus.hpp"

namespace rtuscope::test {

using Bytes = std::vector<std::uint8_t>;

// Makes one of the outputs (text, CSV, JSONL ...) writing into a file: what the tests that
// run every output alike take.
using MakeSink = std::function<std::unique_ptr<RecordSink>(std::FILE*)>;

// A fresh temporary directory, removed with everything in it (even what a test made
// unreadable).
class TempDir {
  public:
    TempDir() {
        path_ = std::filesystem::temp_directory_path() /
                ("rtuscope_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter_++));
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::permissions(path_, std::filesystem::perms::owner_all, ec);
        std::filesystem::remove_all(path_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    // The path of `name` in the directory.
    [[nodiscard]] std::string file(const std::string& name) const { return path_ / name; }
    // Writes `content` to `name` in the directory; its path.
    std::string write(const std::string& name, const std::string& content) const {
        const std::string path = file(name);
        std::ofstream(path, std::ios::binary) << content;
        return path;
    }
    [[nodiscard]] std::string path() const { return path_.string(); }

  private:
    static inline int counter_ = 0;
    std::filesystem::path path_;
};

// The four seed devices at slaves 1-4 (where the benchmark traffic has them); false when
// one of their bundled profiles is missing.
[[nodiscard]] inline bool assign_seed_devices(Bus& bus) {
    const char* const names[] = {"zb-uvi485", "sensor-analyser", "pdu485", "zyi-relay"};
    for (std::uint8_t slave = 1; slave <= 4; ++slave) {
        if (!bus.assign(slave, names[slave - 1])) return false;
    }
    return true;
}

// The bytes followed by their CRC-16/MODBUS, low byte first.
inline Bytes with_crc(Bytes frame) {
    const std::uint16_t crc = crc16_modbus(frame);
    frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    frame.push_back(static_cast<std::uint8_t>(crc >> 8));
    return frame;
}

inline Bytes concat(std::initializer_list<Bytes> parts) {
    Bytes all;
    for (const Bytes& p : parts) all.insert(all.end(), p.begin(), p.end());
    return all;
}

// The frames back to back, as a raw dump of the line holds them.
inline std::string raw_dump(const std::vector<Bytes>& frames) {
    std::string dump;
    for (const Bytes& frame : frames) dump.append(frame.begin(), frame.end());
    return dump;
}

inline constexpr Nanos kMs = 1'000'000;

// Builds a chunk stream on a simulated 9600 8N1 line.
class Line {
  public:
    explicit Line(LineSettings settings = {}) : char_(settings.char_time()) {}

    // Bytes sent back to back, delivered one byte per chunk (a logic analyser).
    Line& send_per_byte(const Bytes& bytes) {
        for (std::uint8_t b : bytes) {
            now_ += char_;
            chunks_.push_back({now_, "", {b}, 0, {}});
        }
        return *this;
    }
    // Bytes sent back to back, delivered as one chunk when the last has arrived.
    Line& send_chunk(const Bytes& bytes) {
        now_ += char_ * static_cast<Nanos>(bytes.size());
        chunks_.push_back({now_, "", bytes, 0, {}});
        return *this;
    }
    Line& silence(double characters) {
        now_ += static_cast<Nanos>(characters * static_cast<double>(char_));
        return *this;
    }
    Line& silence_ms(double ms) {
        now_ += static_cast<Nanos>(ms * 1e6);
        return *this;
    }
    // A chunk handed over at an absolute time (USB batching).
    Line& deliver_at(Nanos time, const Bytes& bytes) {
        now_ = time;
        chunks_.push_back({time, "", bytes, 0, {}});
        return *this;
    }
    [[nodiscard]] const std::vector<Chunk>& chunks() const { return chunks_; }
    [[nodiscard]] Nanos char_time() const { return char_; }

  private:
    Nanos char_;
    Nanos now_ = 0;
    std::vector<Chunk> chunks_;
};

// Framer and pairing wired as in the pipeline; records collected in order. `options`:
// the framer's, but for its expectation (the pairing).
struct Harness {
    explicit Harness(FramerOptions options = {})
        : transactions({kNanosPerSecond, &standard_rules()},
                       [this](Record&& r) { records.push_back(std::move(r)); }),
          framer(
              [&] {
                  FramerOptions o = options;
                  o.expectation = &transactions;
                  return o;
              }(),
              [this](Frame& f) { transactions.push(f); }) {}

    std::vector<Record>& run(const std::vector<Chunk>& chunks) {
        for (const Chunk& c : chunks) {
            input_bytes += c.bytes.size();
            framer.push(c);
        }
        framer.finish();
        transactions.finish();
        return records;
    }
    // Untimed bytes in chunks of `chunk` bytes, like a raw dump.
    std::vector<Record>& run_raw(const Bytes& bytes, std::size_t chunk = 4096) {
        std::vector<Chunk> chunks;
        for (std::size_t i = 0; i < bytes.size(); i += chunk) {
            Chunk c;
            c.bytes.assign(
                bytes.begin() + static_cast<std::ptrdiff_t>(i),
                bytes.begin() + static_cast<std::ptrdiff_t>(std::min(bytes.size(), i + chunk)));
            chunks.push_back(std::move(c));
        }
        return run(chunks);
    }
    [[nodiscard]] std::size_t output_bytes() const {
        return std::accumulate(
            records.begin(), records.end(), std::size_t{0},
            [](std::size_t n, const Record& r) { return n + r.frame.bytes.size(); });
    }

    std::vector<Record> records;
    std::size_t input_bytes = 0;
    Transactions transactions;
    Framer framer;
};

// TZ for one test: the text and the daily lines go by local time.
class ScopedZone {
  public:
    explicit ScopedZone(const char* zone) {
        if (const char* old = std::getenv("TZ")) old_ = old;
        ::setenv("TZ", zone, 1);
        ::tzset();
    }
    ~ScopedZone() {
        if (old_) {
            ::setenv("TZ", old_->c_str(), 1);
        } else {
            ::unsetenv("TZ");
        }
        ::tzset();
    }
    ScopedZone(const ScopedZone&) = delete;
    ScopedZone& operator=(const ScopedZone&) = delete;

  private:
    std::optional<std::string> old_;
};

// Keeps everything run_pipeline delivers.
class CollectingSink final : public RecordSink {
  public:
    void begin(const SessionInfo& s) override { session = s; }
    void record(const Record& r) override { records.push_back(r); }
    void end(const Totals& t, const std::vector<std::string>& r) override {
        totals = t;
        remarks = r;
        ended = true;
    }
    SessionInfo session;
    std::vector<Record> records;
    Totals totals;
    std::vector<std::string> remarks;
    bool ended = false;
};

}  // namespace rtuscope::test
