// Recording a line (sniff -w): rotation, the ring of files, trigger windows, and reading
// the files back as one stream. The line is the benchmark traffic's, fed through the
// recorder exactly as a live port's chunks are.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "input/capture_writer.hpp"
#include "input/joined_source.hpp"
#include "recording/recorder.hpp"
#include "support.hpp"
#include "traffic.hpp"

namespace rtuscope {
namespace {

using test::CollectingSink;
using test::TempDir;

// Hands over chunks held in memory, as a port would.
class ChunkList final : public ChunkSource {
  public:
    ChunkList(std::vector<Chunk> chunks, SourceInfo info)
        : chunks_(std::move(chunks)), info_(std::move(info)) {}
    [[nodiscard]] const SourceInfo& info() const override { return info_; }
    Result<bool> next(Chunk& out) override {
        if (at_ == chunks_.size()) return false;
        out = chunks_[at_++];
        return true;
    }

  private:
    std::vector<Chunk> chunks_;
    SourceInfo info_;
    std::size_t at_ = 0;
};

struct Line {
    std::vector<Chunk> chunks;
    SourceInfo info;
};

// A few seconds of a polled 9600-baud line, as a USB adapter delivers it, starting on
// 2026-11-28 at 03:00 UTC.
Line polled_line(std::uint64_t frames = 4000) {
    bench::TrafficOptions options;
    options.frames = frames;
    options.baud = 9600;
    Line line;
    constexpr Nanos kStart = 1'795'834'800 * kNanosPerSecond;
    Nanos shift = kNoTime;
    bench::generate_traffic(options, [&](const Chunk& c) {
        if (!has_time(shift)) shift = kStart - c.time;
        Chunk shifted = c;
        shifted.time += shift;
        line.chunks.push_back(std::move(shifted));
    });
    line.info.name = "test";
    line.info.format = "live";
    line.info.timed = true;
    line.info.time_base = TimeBase::unix_time;
    line.info.line = LineSettings{};
    line.info.line->baud = 9600;
    return line;
}

// What a decode shows of each record: enough to tell any loss, duplicate or change.
std::vector<std::string> decoded(ChunkSource& source) {
    CollectingSink sink;
    PipelineOptions options;
    const Status status = run_pipeline(source, options, sink);
    EXPECT_TRUE(status) << status.error().to_string();
    std::vector<std::string> out;
    for (const Record& r : sink.records) {
        std::string notes;
        for (const Note& n : r.notes) notes += std::string(n.id) + ";";
        out.push_back(fmt::format("{} {} {} {}", r.frame.start, static_cast<int>(r.kind),
                                  fmt::join(r.frame.bytes, " "), notes));
    }
    return out;
}

std::vector<std::string> decoded_files(const std::vector<std::string>& paths) {
    auto source = open_joined(paths, InputFormat::automatic, {});
    EXPECT_TRUE(source) << source.error().to_string();
    if (!source) return {};
    return decoded(**source);
}

// Records `line` with `options` to completion; the recorder, for its counts.
std::shared_ptr<Recorder> record(const Line& line, RecordingOptions options,
                                 const std::function<std::unique_ptr<RecordSink>(Recorder&)>&
                                     make_sink = {}) {
    auto recorder = std::make_shared<Recorder>(options, capture_header(line.info));
    EXPECT_TRUE(recorder->open(line.chunks.front().time));
    auto source = record_chunks(std::make_unique<ChunkList>(line.chunks, line.info), recorder);
    std::unique_ptr<RecordSink> sink =
        make_sink ? make_sink(*recorder) : std::make_unique<CollectingSink>();
    const Status status = run_pipeline(*source, PipelineOptions{}, *sink);
    EXPECT_TRUE(status) << status.error().to_string();
    return recorder;
}

std::vector<std::string> files_in(const TempDir& dir) {
    std::vector<std::string> files;
    for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
        files.push_back(entry.path().string());
    }
    std::sort(files.begin(), files.end());
    return files;
}

std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(StampedName, PutsTheUtcStartBeforeTheFirstDot) {
    constexpr Nanos t = 1'795'834'800 * kNanosPerSecond + 999'999'999;  // 2026-11-28 03:00:00
    EXPECT_EQ(stamped_name("bus.rtucap", t), "bus-20261128T030000Z.rtucap");
    EXPECT_EQ(stamped_name("/var/log/rtu/bus.rtucap.zst", t),
              "/var/log/rtu/bus-20261128T030000Z.rtucap.zst");
    EXPECT_EQ(stamped_name("dir.d/bus", t), "dir.d/bus-20261128T030000Z");
    EXPECT_EQ(stamped_name(".hidden.rtucap", t), ".hidden-20261128T030000Z.rtucap");
}

TEST(Rotation, FilesByTheClockDecodeTogetherAsTheUnrotatedRecording) {
    const Line line = polled_line();
    const TempDir dir;
    RecordingOptions whole;
    whole.path = dir.file("whole.rtucap");
    record(line, whole);
    const TempDir rotated_dir;
    RecordingOptions rotated;
    rotated.path = rotated_dir.file("bus.rtucap");
    rotated.rotation.period = 10 * kNanosPerSecond;
    const auto recorder = record(line, rotated);

    const std::vector<std::string> files = files_in(rotated_dir);
    const Nanos span = line.chunks.back().time - line.chunks.front().time;
    ASSERT_GE(files.size(), static_cast<std::size_t>(span / (10 * kNanosPerSecond)));
    EXPECT_EQ(recorder->counts().files, files.size());
    // Each file is named after the 10 s it holds, and holds the frames that end in them
    // (a frame's start may lie in the interval before).
    constexpr Nanos kStart = 1'795'834'800 * kNanosPerSecond;
    EXPECT_EQ(files.front(), rotated_dir.file("bus-20261128T030000Z.rtucap"));
    for (std::size_t i = 0; i < files.size(); ++i) {
        const Nanos from = kStart + static_cast<Nanos>(i) * 10 * kNanosPerSecond;
        EXPECT_EQ(files[i], stamped_name(rotated.path, from));
        auto source = open_joined({files[i]}, InputFormat::automatic, {});
        ASSERT_TRUE(source);
        for (const std::string& record : decoded(**source)) {
            const Nanos start = std::stoll(record);
            EXPECT_GE(start, from - kNanosPerSecond);
            EXPECT_LT(start, from + 10 * kNanosPerSecond);
        }
    }
    const std::vector<std::string> expected = decoded_files({whole.path});
    ASSERT_GT(expected.size(), 3000U);
    EXPECT_EQ(decoded_files(files), expected);
}

TEST(Rotation, FilesBySizeStayUnderItAndDecodeTogetherAsTheUnrotatedRecording) {
    const Line line = polled_line();
    const TempDir dir;
    RecordingOptions whole;
    whole.path = dir.file("whole.rtucap");
    record(line, whole);
    const TempDir rotated_dir;
    RecordingOptions rotated;
    rotated.path = rotated_dir.file("bus.rtucap");
    rotated.rotation.max_bytes = 20'000;
    record(line, rotated);

    const std::vector<std::string> files = files_in(rotated_dir);
    ASSERT_GT(files.size(), 5U);
    for (const std::string& file : files) {
        EXPECT_LE(std::filesystem::file_size(file), 20'000U) << file;
        // Full, but for the last.
        if (file != files.back()) {
            EXPECT_GT(std::filesystem::file_size(file), 19'800U) << file;
        }
    }
    const std::vector<std::string> whole_records = decoded_files({whole.path});
    EXPECT_EQ(decoded_files(files), whole_records);
    // Frames were cut at the boundaries (alone, the files give more pieces than the
    // whole), and joined again above.
    std::size_t pieces = 0;
    for (const std::string& file : files) pieces += decoded_files({file}).size();
    EXPECT_GT(pieces, whole_records.size());
}

TEST(Rotation, EachFileDecodesAloneWithTheHeader) {
    const Line line = polled_line(1000);
    const TempDir dir;
    RecordingOptions rotated;
    rotated.path = dir.file("bus.rtucap");
    rotated.rotation.period = kNanosPerSecond;
    record(line, rotated);
    const std::vector<std::string> files = files_in(dir);
    ASSERT_GE(files.size(), 3U);
    const std::string middle = read_file(files[1]);
    EXPECT_TRUE(middle.starts_with(capture_header(line.info))) << middle.substr(0, 200);
    EXPECT_NE(middle.find("# continues " + files[0] + "\n"), std::string::npos);
    EXPECT_TRUE(middle.ends_with("# continued in " + files[2] + "\n"));
    auto source = open_joined({files[1]}, InputFormat::automatic, {});
    ASSERT_TRUE(source);
    EXPECT_EQ((*source)->info().line->baud, 9600U);
    EXPECT_FALSE(decoded(**source).empty());
    EXPECT_TRUE((*source)->ended_by_stop());  // a frame cut at its end is cut by rotation
}

TEST(Rotation, KeepsOnlyTheNewestFiles) {
    const Line line = polled_line();
    const TempDir all_dir;
    RecordingOptions all;
    all.path = all_dir.file("bus.rtucap");
    all.rotation.period = kNanosPerSecond;
    record(line, all);
    const TempDir ring_dir;
    RecordingOptions ring = all;
    ring.path = ring_dir.file("bus.rtucap");
    ring.rotation.keep_files = 3;
    const auto recorder = record(line, ring);

    const std::vector<std::string> every = files_in(all_dir);
    const std::vector<std::string> kept = files_in(ring_dir);
    ASSERT_GT(every.size(), 3U);
    ASSERT_EQ(kept.size(), 3U);
    EXPECT_EQ(recorder->counts().files, every.size());
    for (std::size_t i = 0; i < 3; ++i) {
        const std::string& newest = every[every.size() - 3 + i];
        EXPECT_EQ(std::filesystem::path(kept[i]).filename(), std::filesystem::path(newest).filename());
        std::string kept_text = read_file(kept[i]);
        std::string all_text = read_file(newest);
        // The same but for the directory in the names of the files before and after.
        for (std::string* text : {&kept_text, &all_text}) {
            for (const std::string& dir : {ring_dir.path(), all_dir.path()}) {
                for (std::size_t at = text->find(dir); at != std::string::npos; at = text->find(dir)) {
                    text->replace(at, dir.size(), "DIR");
                }
            }
        }
        EXPECT_EQ(kept_text, all_text);
    }
}

TEST(Rotation, TheSignalStartsTheNextFileAtOnce) {
    const Line line = polled_line(1000);
    const TempDir dir;
    std::atomic<bool> rotate{false};
    RecordingOptions options;
    options.path = dir.file("bus.rtucap");
    options.rotation.rotate_now = &rotate;
    options.rotation.stamp_names = true;
    // A sink that asks for a rotation at the 5th record (in the first second), as SIGUSR1
    // does.
    struct Asking final : RecordSink {
        std::atomic<bool>& flag;
        int n = 0;
        explicit Asking(std::atomic<bool>& f) : flag(f) {}
        void begin(const SessionInfo&) override {}
        void end(const Totals&, const std::vector<std::string>&) override {}
        void record(const Record&) override {
            if (++n == 5) flag.store(true);
        }
    };
    record(line, options, [&](Recorder&) { return std::make_unique<Asking>(rotate); });
    ASSERT_EQ(files_in(dir).size(), 2U);
    // The second file starts within the first one's second; its name sorts after it.
    EXPECT_EQ(files_in(dir)[0], dir.file("bus-20261128T030000Z.rtucap"));
    EXPECT_EQ(files_in(dir)[1], dir.file("bus-20261128T030000Z_002.rtucap"));
    EXPECT_EQ(decoded_files(files_in(dir)), decoded(*std::make_unique<ChunkList>(line.chunks, line.info)));
}

// The data lines of capture files, comments left out.
std::vector<std::string> data_lines(const std::vector<std::string>& files) {
    std::vector<std::string> lines;
    for (const std::string& file : files) {
        std::istringstream in(read_file(file));
        for (std::string line; std::getline(in, line);) {
            if (!line.empty() && line[0] != '#') lines.push_back(line);
        }
    }
    return lines;
}

// Tells the recorder of every record `is_event` picks, as the trigger sink does.
class EventSink final : public RecordSink {
  public:
    EventSink(Recorder& recorder, std::function<bool(const Record&)> is_event)
        : recorder_(recorder), is_event_(std::move(is_event)) {}
    void begin(const SessionInfo&) override {}
    void end(const Totals&, const std::vector<std::string>&) override {}
    void record(const Record& r) override {
        if (!is_event_(r)) return;
        recorder_.event(r.frame.start, r.frame.end, fmt::format("record {}", r.number));
        events.push_back(r);
    }
    std::vector<Record> events;

  private:
    Recorder& recorder_;
    std::function<bool(const Record&)> is_event_;
};

struct WindowCase {
    const char* name;
    std::uint64_t every;  // every n-th record is an event
    Nanos pre;
    Nanos post;
};

class TriggerWindowsTest : public ::testing::TestWithParam<WindowCase> {};

TEST_P(TriggerWindowsTest, HoldExactlyTheEventsWithTheirSecondsBeforeAndAfter) {
    const WindowCase& c = GetParam();
    const Line line = polled_line();
    const TempDir dir;
    RecordingOptions options;
    options.path = dir.file("bus.rtucap");
    options.windows = TriggerWindows{c.pre, std::size_t{64} << 20, c.post, 2 * kNanosPerSecond};
    std::vector<Record> events;
    const auto recorder = record(line, options, [&](Recorder& r) {
        return std::make_unique<EventSink>(r, [&](const Record& record) {
            if (record.number % c.every != 0) return false;
            events.push_back(record);
            return true;
        });
    });
    ASSERT_GE(events.size(), 3U);

    // Exactly the chunks within some event's window, and the first after it, each once.
    std::vector<bool> inside(line.chunks.size(), false);
    for (const Record& e : events) {
        for (std::size_t i = 0; i < line.chunks.size(); ++i) {
            const Nanos t = line.chunks[i].time;
            if (t < e.frame.start - c.pre) continue;
            inside[i] = true;
            if (t > e.frame.end + c.post) break;
        }
    }
    std::vector<std::string> expected;
    for (std::size_t i = 0; i < line.chunks.size(); ++i) {
        if (!inside[i]) continue;
        const std::string text = capture_line(line.chunks[i]);
        expected.push_back(text.substr(0, text.size() - 1));
    }
    std::size_t windows = 0;
    const std::vector<std::string> files = files_in(dir);
    EXPECT_EQ(data_lines(files), expected);
    // One window per run of overlapping windows.
    Nanos end = kNoTime;
    for (const Record& e : events) {
        if (!has_time(end) || e.frame.start - c.pre > end) ++windows;
        end = has_time(end) ? std::max(end, e.frame.end + c.post) : e.frame.end + c.post;
    }
    EXPECT_EQ(files.size(), windows);
    EXPECT_EQ(recorder->counts().windows, windows);
    EXPECT_EQ(recorder->counts().events, events.size());
    // Each window decodes alone, its events in it.
    std::size_t found = 0;
    for (const std::string& file : files) {
        auto source = open_joined({file}, InputFormat::automatic, {});
        ASSERT_TRUE(source);
        const std::vector<std::string> records = decoded(**source);
        for (const Record& e : events) {
            const std::string start = std::to_string(e.frame.start) + " ";
            found += static_cast<std::size_t>(std::count_if(records.begin(), records.end(), [&](const std::string& r) {
                return r.starts_with(start);
            }));
        }
        EXPECT_NE(read_file(file).find("# event: record "), std::string::npos);
    }
    EXPECT_EQ(found, events.size());
}

INSTANTIATE_TEST_SUITE_P(
    Recording, TriggerWindowsTest,
    ::testing::Values(WindowCase{"apart", 1000, 2 * kNanosPerSecond, kNanosPerSecond},
                      WindowCase{"overlapping", 40, 2 * kNanosPerSecond, kNanosPerSecond},
                      WindowCase{"no_seconds_around", 700, 0, 0}),
    [](const auto& p) { return std::string(p.param.name); });

TEST(TriggerWindows, WithoutAnEventNothingIsWritten) {
    const Line line = polled_line(1000);
    const TempDir dir;
    RecordingOptions options;
    options.path = dir.file("bus.rtucap");
    options.windows = TriggerWindows{};
    const auto recorder = record(line, options);
    EXPECT_TRUE(files_in(dir).empty());
    EXPECT_EQ(recorder->counts().windows, 0U);
}

TEST(TriggerWindows, HoldNoMoreThanTheBytesAllowed) {
    const Line line = polled_line();
    const TempDir dir;
    RecordingOptions options;
    options.path = dir.file("bus.rtucap");
    // 60 s before the event asked, but only 2 KB of capture text held.
    options.windows = TriggerWindows{60 * kNanosPerSecond, 2048, 0, 2 * kNanosPerSecond};
    record(line, options, [&](Recorder& r) {
        return std::make_unique<EventSink>(r, [](const Record& record) { return record.number == 3000; });
    });
    const std::vector<std::string> files = files_in(dir);
    ASSERT_EQ(files.size(), 1U);
    std::size_t held = 0;
    for (const std::string& data : data_lines(files)) held += data.size() + 1;
    EXPECT_LE(held, 2048U + 200);  // the held bytes, then the event's own chunks
    EXPECT_GT(held, 1024U);
}

TEST(JoinedInput, RefusesFilesOutOfOrderOrOfAnotherLine) {
    const Line line = polled_line(1000);
    const TempDir dir;
    RecordingOptions options;
    options.path = dir.file("bus.rtucap");
    options.rotation.period = kNanosPerSecond;
    record(line, options);
    std::vector<std::string> files = files_in(dir);
    ASSERT_GE(files.size(), 2U);
    std::swap(files[0], files[1]);
    auto source = open_joined(files, InputFormat::automatic, {});
    ASSERT_TRUE(source);
    CollectingSink sink;
    const Status status = run_pipeline(**source, PipelineOptions{}, sink);
    ASSERT_FALSE(status);
    EXPECT_EQ(status.error().file, files[1]);
    EXPECT_NE(status.error().message.find("give the files in time order"), std::string::npos);

    const std::string other = dir.write("other.rtucap", "# rtuscope capture v1\n# serial 19200 8N1\n1795834900.0 01\n");
    auto mixed = open_joined({files[1], other}, InputFormat::automatic, {});
    ASSERT_TRUE(mixed);
    const Status refused = run_pipeline(**mixed, PipelineOptions{}, sink);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().file, other);
    EXPECT_NE(refused.error().message.find("line settings 19200 8N1 differ"), std::string::npos);
}

TEST(JoinedInput, ExpandsPatternsInNameOrder) {
    const TempDir dir;
    dir.write("b-2.rtucap", "x");
    dir.write("b-1.rtucap", "x");
    dir.write("a.rtucap", "x");
    auto files = expand_inputs({dir.file("b-*.rtucap"), dir.file("a.rtucap")});
    ASSERT_TRUE(files);
    EXPECT_EQ(*files, (std::vector<std::string>{dir.file("b-1.rtucap"), dir.file("b-2.rtucap"),
                                                 dir.file("a.rtucap")}));
    auto none = expand_inputs({dir.file("c-*.rtucap")});
    ASSERT_FALSE(none);
    EXPECT_EQ(none.error().message, "no file matches this pattern");
}

}  // namespace
}  // namespace rtuscope
