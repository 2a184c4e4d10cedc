// The pcaps users hand rtuscope, built here byte by byte: packets that hold several frames
// (a serial sniffer that cuts packets at silences), packets the snap length cut, pcapng
// files whose interfaces have different link types (mergecap's), TCP streams that split
// frames over segments, and captures where Modbus RTU shares the network with Modbus/TCP,
// S7comm and EtherNet/IP.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "input/mbap.hpp"
#include "input/pcap.hpp"
#include "input/sources.hpp"
#include "pcap_builders.hpp"
#include "output/sinks.hpp"
#include "stats/report.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using namespace test;  // Bytes, with_crc, the pcap builders

constexpr Nanos kT0 = 1'763'798'400'000'000'000;  // 2025-11-22, a whole second
const Nanos kChar = LineSettings{}.char_time();   // 9600 8N1
constexpr std::uint32_t kUser0 = 147;

const Bytes kRequest = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
const Bytes kAnswer = with_crc({0x01, 0x03, 0x04, 0x00, 0x01, 0x00, 0x02});
const Bytes kRequest2 = with_crc({0x02, 0x04, 0x00, 0x10, 0x00, 0x01});
const Bytes kAnswer2 = with_crc({0x02, 0x04, 0x02, 0x12, 0x34});

Bytes bad_crc(Bytes frame) {
    frame.back() ^= 0xFF;
    return frame;
}

Bytes first(const Bytes& b, std::size_t n) {
    return {b.begin(), b.begin() + static_cast<std::ptrdiff_t>(n)};
}

Bytes from(const Bytes& b, std::size_t n) {
    return {b.begin() + static_cast<std::ptrdiff_t>(n), b.end()};
}

Drained read(const std::string& content) {
    auto source = source_from_memory(content, "mem.pcap", InputFormat::automatic);
    EXPECT_TRUE(source.ok()) << source.error().to_string();
    if (!source.ok()) return {};
    return drain(**source);
}

// What the pipeline makes of a file.
struct Decoded {
    std::vector<Record> records;
    Totals totals;
    std::vector<std::string> remarks;
    std::optional<Error> error;
};

Decoded decode(const std::string& content, PipelineOptions options = {},
               const PcapOptions& pcap = {}) {
    Decoded d;
    auto source = source_from_memory(content, "mem.pcap", InputFormat::automatic, pcap);
    EXPECT_TRUE(source.ok()) << source.error().to_string();
    if (!source.ok()) return d;
    CollectingSink collect;
    Status status = run_pipeline(**source, options, collect);
    if (!status) d.error = status.error();
    d.records = collect.records;
    d.totals = collect.totals;
    d.remarks = collect.remarks;
    return d;
}

// `rtuscope stats` as text.
std::string stats_text(const std::string& content) {
    auto source = source_from_memory(content, "mem.pcap", InputFormat::automatic);
    EXPECT_TRUE(source.ok()) << source.error().to_string();
    if (!source.ok()) return {};
    std::FILE* out = std::tmpfile();
    auto sink = make_stats_sink(out, StatsFormat::text);
    EXPECT_TRUE(run_pipeline(**source, {}, *sink).ok());
    sink.reset();
    std::rewind(out);
    std::string text;
    char buffer[4096];
    for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, out)) > 0;) text.append(buffer, n);
    std::fclose(out);
    return text;
}

bool has_remark(const std::vector<std::string>& remarks, const std::string& remark) {
    return std::find(remarks.begin(), remarks.end(), remark) != remarks.end();
}

std::string all_of(const std::vector<std::string>& lines) {
    std::string text;
    for (const std::string& line : lines) text += line + "\n";
    return text;
}

// --- several frames in one packet ---------------------------------------------------------

// A serial sniffer that cuts packets at a 10 ms silence (SerialPCAP) puts a request, its
// answer and the next request in one packet when they come closer than that.
TEST(PcapPackets, SeveralFramesInOnePacketAreFramed) {
    const Bytes three = concat({kRequest, kAnswer, kRequest2});
    const Nanos second = kT0 + 50 * kMs;
    const std::string file = pcap_file(kUser0, {{kT0, kAnswer2}, {second, three}});

    const Drained d = read(file);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_TRUE(d.chunks[0].whole_frame);  // one frame by length and CRC
    EXPECT_FALSE(d.chunks[1].whole_frame);
    EXPECT_TRUE(d.chunks[1].packet);
    EXPECT_EQ(d.chunks[1].time, second);

    const Decoded out = decode(file);
    ASSERT_EQ(out.records.size(), 4U);
    const Record& request = out.records[1];
    const Record& answer = out.records[2];
    const Record& next = out.records[3];
    EXPECT_EQ(request.kind, Kind::request);
    EXPECT_EQ(request.frame.bytes, kRequest);
    EXPECT_EQ(answer.kind, Kind::response);
    EXPECT_EQ(answer.frame.bytes, kAnswer);
    EXPECT_EQ(answer.request_number, request.number);
    EXPECT_EQ(next.kind, Kind::request);
    EXPECT_EQ(next.frame.bytes, kRequest2);
    // The packet's time is its first frame's start; that frame follows a silence the
    // capture measured. The frames after it follow back to back: estimates, no silence.
    EXPECT_EQ(request.frame.start, second);
    EXPECT_EQ(request.frame.silence_before, second - out.records[0].frame.end);
    EXPECT_EQ(answer.frame.start, request.frame.end);
    EXPECT_EQ(answer.frame.silence_before, kNoTime);
    EXPECT_EQ(answer.latency, kNoTime);
    EXPECT_EQ(next.frame.start, answer.frame.end);
    EXPECT_EQ(next.frame.silence_before, kNoTime);
    EXPECT_EQ(out.totals.invalid, 0U);
    EXPECT_EQ(out.totals.crc_bad, 0U);
}

// After a packet of several frames, where the last ended is not known (the frames after
// the first are placed back to back): the silence before the next packet is not measured,
// and the answer in it has no turnaround. After a packet of one frame it is.
TEST(PcapPackets, NoSilenceIsMeasuredAfterAPacketOfSeveralFrames) {
    const Bytes write = with_crc({0x02, 0x10, 0x00, 0x10, 0x00, 0x01, 0x02, 0x12, 0x34});
    const Bytes written = with_crc({0x02, 0x10, 0x00, 0x10, 0x00, 0x01});
    const Nanos second = kT0 + 100 * kMs;
    for (const bool noise_after : {false, true}) {
        SCOPED_TRACE(noise_after ? "a frame and noise" : "three frames");
        const Bytes first_packet =
            noise_after ? concat({write, {0xFF}}) : concat({kRequest, kAnswer, write});
        const Decoded out = decode(pcap_file(kUser0, {{kT0, first_packet}, {second, written}}));
        ASSERT_FALSE(out.records.empty());
        const Record& answer = out.records.back();
        EXPECT_EQ(answer.kind, Kind::response);
        EXPECT_EQ(answer.frame.start, second);
        EXPECT_EQ(answer.frame.silence_before, kNoTime);
        EXPECT_EQ(answer.latency, kNoTime);
        EXPECT_NE(answer.request_number, 0U);
    }
    const Decoded out = decode(pcap_file(kUser0, {{kT0, concat({write, {0xFF}})},
                                                  {second - 50 * kMs, written},
                                                  {second, kRequest}}));
    ASSERT_EQ(out.records.size(), 4U);
    EXPECT_EQ(out.records[2].frame.silence_before, kNoTime);
    EXPECT_EQ(out.records[3].frame.silence_before, second - out.records[2].frame.end);
}

// What follows a packet's frames within the packet is framed too: a frame and noise.
TEST(PcapPackets, AFrameAndNoiseInOnePacket) {
    const Decoded out = decode(pcap_file(kUser0, {{kT0, concat({kRequest, {0xFF, 0xFF}})}}));
    ASSERT_EQ(out.records.size(), 2U);
    EXPECT_EQ(out.records[0].kind, Kind::request);
    EXPECT_EQ(out.records[1].kind, Kind::noise);
    EXPECT_EQ(out.records[1].frame.bytes, Bytes({0xFF, 0xFF}));
}

// A packet's start is a frame boundary: a frame does not run on from one packet into the
// next, however soon it comes.
TEST(PcapPackets, APacketBoundaryIsAFrameBoundary) {
    const Decoded out = decode(pcap_file(
        kUser0, {{kT0, concat({kAnswer2, first(kRequest, 5)})}, {kT0 + 7 * kChar, from(kRequest, 5)}}));
    ASSERT_GE(out.records.size(), 2U);
    EXPECT_EQ(out.records[0].frame.bytes, kAnswer2);
    for (std::size_t i = 1; i < out.records.size(); ++i) {
        EXPECT_NE(out.records[i].frame.bytes, kRequest) << i;
        EXPECT_NE(out.records[i].kind, Kind::request) << i;
    }
}

// The first frame of a packet keeps the silence the capture measured before it: an
// answer 1 ms after its request (sooner than t3.5) gets its turnaround, though the
// packet also holds noise.
TEST(PcapPackets, TheFirstFrameOfAPacketHasItsTurnaround) {
    // pcap_file stamps whole microseconds.
    const Nanos answer_at = kT0 + (8 * kChar + kMs) / 1000 * 1000;
    const Decoded out = decode(
        pcap_file(kUser0, {{kT0, kRequest}, {answer_at, concat({kAnswer, {0x00}})}}));
    ASSERT_EQ(out.records.size(), 3U);
    EXPECT_EQ(out.records[1].kind, Kind::response);
    EXPECT_EQ(out.records[1].frame.start, answer_at);
    EXPECT_EQ(out.records[1].latency, answer_at - out.records[0].frame.end);
    EXPECT_GT(out.records[1].latency, kMs - 1000);
}

// Packets closer together than the line settings let frames be (a 19200-baud line read
// as 9600): a packet's frames still start at its time, not after the last frame's end as
// the settings place it.
TEST(PcapPackets, APacketKeepsItsTimeWhenTheSettingsEndTheLastFrameLater) {
    // The request takes 8 characters at 9600; pcap_file stamps whole microseconds.
    const Nanos second = kT0 + 4 * kChar / 1000 * 1000;
    const Decoded out = decode(
        pcap_file(kUser0, {{kT0, kRequest}, {second, concat({kAnswer, kRequest2})}}));
    ASSERT_EQ(out.records.size(), 3U);
    EXPECT_EQ(out.records[1].frame.start, second);
    EXPECT_EQ(out.records[1].frame.silence_before, kNoTime);
    EXPECT_EQ(out.records[1].latency, kNoTime);
    EXPECT_EQ(out.records[2].frame.start, out.records[1].frame.end);
}

// --- packets the capture's snap length cut ---------------------------------------------------

TEST(PcapPackets, APacketCutBySnapLengthIsNoErrorOfTheBus) {
    const std::string file = pcap_file(
        kUser0, {{kT0, kRequest}, {kT0 + 20 * kMs, first(kAnswer, 5), static_cast<std::uint32_t>(kAnswer.size())}});
    const Decoded out = decode(file);
    ASSERT_EQ(out.records.size(), 2U);
    const Record& cut = out.records[1];
    EXPECT_EQ(cut.frame.bytes, first(kAnswer, 5));
    ASSERT_EQ(cut.notes.size(), 1U);
    EXPECT_STREQ(cut.notes.begin()->id, "frame.cut_by_snaplen");
    EXPECT_EQ(cut.notes.begin()->text, "packet cut by the capture's snap length (4 bytes not captured)");
    EXPECT_EQ(cut.frame.crc.status, CrcStatus::none);
    // It answers the request: the bus answered, the capture kept part of it.
    EXPECT_EQ(cut.request_number, out.records[0].number);
    EXPECT_EQ(out.totals.invalid, 0U);
    EXPECT_EQ(out.totals.crc_bad, 0U);
    EXPECT_EQ(out.totals.unanswered, 0U);
    EXPECT_TRUE(has_remark(out.remarks,
                           "1 of 2 packets was cut by the capture's snap length: their last bytes "
                           "are missing (no error of the bus)"))
        << all_of(out.remarks);
    const std::string stats = stats_text(file);
    EXPECT_NE(stats.find("bus: 1 frame, 13 bytes; 0 invalid"), std::string::npos) << stats;
    // The request has its outcome: answered, its turnaround measured.
    EXPECT_NE(stats.find("1  03  Read Holding Registers    1    1    0       0       0    0"),
              std::string::npos)
        << stats;
}

// A sniffer's packet of three frames cut in the third: two frames, and what the capture
// kept of the third.
TEST(PcapPackets, APacketOfFramesCutInItsLast) {
    const Bytes three = concat({kRequest, kAnswer, kRequest2});
    const Decoded out = decode(
        pcap_file(kUser0, {{kT0, first(three, 20), static_cast<std::uint32_t>(three.size())}}));
    ASSERT_EQ(out.records.size(), 3U);
    EXPECT_EQ(out.records[0].kind, Kind::request);
    EXPECT_EQ(out.records[1].kind, Kind::response);
    EXPECT_EQ(out.records[2].frame.bytes, first(kRequest2, 3));
    EXPECT_TRUE(out.records[2].notes.has("frame.cut_by_snaplen"));
    EXPECT_EQ(out.totals.invalid, 0U);
}

// Over TCP the snap length cuts the segment's payload; the stream goes on after the bytes
// the capture did not keep.
TEST(PcapPackets, ATcpSegmentCutBySnapLength) {
    Bytes cut = eth_tcp(502, 40000, kAnswer, 1);
    const auto length = static_cast<std::uint32_t>(cut.size());
    cut.resize(14 + 20 + 20 + 4);  // headers and 4 bytes of the answer
    const Decoded out = decode(pcap_file(1, {{kT0, eth_tcp(40000, 502, kRequest, 1)},
                                             {kT0 + 20 * kMs, cut, length},
                                             {kT0 + 40 * kMs, eth_tcp(40000, 502, kRequest2, 9)},
                                             {kT0 + 60 * kMs, eth_tcp(502, 40000, kAnswer2, 10)}}));
    ASSERT_EQ(out.records.size(), 4U);
    EXPECT_EQ(out.records[1].frame.bytes, first(kAnswer, 4));
    EXPECT_TRUE(out.records[1].notes.has("frame.cut_by_snaplen"));
    EXPECT_EQ(out.records[3].kind, Kind::response);
    EXPECT_EQ(out.records[3].frame.bytes, kAnswer2);
    EXPECT_EQ(out.totals.invalid, 0U);
    EXPECT_EQ(out.totals.crc_bad, 0U);
}

// --- pcapng with interfaces of several link types -----------------------------------------

// An Ethernet interface with Modbus RTU over TCP, a serial one (DLT_USER0) and one whose
// link type carries no RTU (802.11): libpcap refuses the file, rtuscope's own reader
// reads it.
std::string mixed_pcapng(bool big_endian = false) {
    Pcapng file(big_endian);
    file.interface(1).interface(static_cast<std::uint16_t>(kUser0)).interface(105);
    const auto us = [](Nanos t) { return static_cast<std::uint64_t>(t / 1000); };
    file.packet(0, us(kT0), eth_tcp(40000, 502, kRequest, 1))
        .packet(1, us(kT0 + 20 * kMs), kAnswer)
        .packet(2, us(kT0 + 30 * kMs), Bytes(24, 0x88))
        .packet(1, us(kT0 + 100 * kMs), kRequest2)
        .packet(0, us(kT0 + 120 * kMs), eth_tcp(502, 40000, kAnswer2, 1));
    return file.str();
}

void expect_mixed_read(const Drained& d) {
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 4U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_EQ(d.chunks[0].channel, "master");
    EXPECT_EQ(d.chunks[0].time, kT0);
    EXPECT_EQ(d.chunks[1].bytes, kAnswer);
    EXPECT_EQ(d.chunks[1].time, kT0 + 20 * kMs);
    EXPECT_EQ(d.chunks[2].bytes, kRequest2);
    EXPECT_EQ(d.chunks[3].bytes, kAnswer2);
    EXPECT_EQ(d.chunks[3].channel, "slave");
    EXPECT_EQ(d.remarks,
              std::vector<std::string>({"skipped 1 of 5 packets: interfaces whose link type "
                                        "carries no Modbus RTU (1 of link type 105)"}));
}

TEST(Pcapng, InterfacesOfSeveralLinkTypes) {
    for (const bool big_endian : {false, true}) {
        SCOPED_TRACE(big_endian ? "big-endian" : "little-endian");
        const std::string file = mixed_pcapng(big_endian);
        EXPECT_EQ(detect_input_format(file), InputFormat::pcap);
        expect_mixed_read(read(file));
        auto own = pcapng_source_from_memory(file, "own.pcapng");
        ASSERT_TRUE(own.ok()) << own.error().to_string();
        expect_mixed_read(drain(**own));
    }
}

// A file is read again from its start by a descriptor of its own; a pipe through the
// bytes libpcap took before it refused the file.
TEST(Pcapng, InterfacesOfSeveralLinkTypesFromAFileAndAPipe) {
    const std::string file = mixed_pcapng();
    TempDir dir;
    const std::string path = dir.write("mixed.pcapng", file);
    auto source = open_source(path, InputFormat::automatic);
    ASSERT_TRUE(source.ok()) << source.error().to_string();
    expect_mixed_read(drain(**source));
    for (const std::size_t cut : {std::size_t{0}, std::size_t{12}, std::size_t{100}}) {
        SCOPED_TRACE(cut);
        std::string rest = file.substr(cut);
        std::FILE* stream = fmemopen(rest.data(), rest.size(), "rb");
        auto piped = pcap_source_from_stream(file.substr(0, cut), stream, true, "-");
        ASSERT_TRUE(piped.ok()) << piped.error().to_string();
        expect_mixed_read(drain(**piped));
    }
}

// An interface of another link type after packets of the first: libpcap refuses the file
// there. A file goes on through rtuscope's reader from the packet libpcap stopped at, no
// packet twice; a pipe cannot be read again, and stops with libpcap's error.
TEST(Pcapng, AnInterfaceOfAnotherLinkTypeAfterPackets) {
    Pcapng file;
    file.interface(static_cast<std::uint16_t>(kUser0))
        .packet(0, 1000, kRequest)
        .packet(0, 2000, kAnswer)
        .interface(1)
        .packet(1, 3000, eth_tcp(40000, 502, kRequest2, 1))
        .packet(0, 4000, kAnswer2);
    TempDir dir;
    const std::string path = dir.write("late.pcapng", file.str());
    for (const bool from_memory : {false, true}) {
        SCOPED_TRACE(from_memory ? "memory" : "file");
        auto source = from_memory ? source_from_memory(file.str(), "late.pcapng", InputFormat::pcap)
                                  : open_source(path, InputFormat::automatic);
        ASSERT_TRUE(source.ok()) << source.error().to_string();
        const Drained d = drain(**source);
        ASSERT_FALSE(d.error) << d.error->to_string();
        ASSERT_EQ(d.chunks.size(), 4U);
        EXPECT_EQ(d.chunks[0].bytes, kRequest);
        EXPECT_EQ(d.chunks[1].bytes, kAnswer);
        EXPECT_EQ(d.chunks[2].bytes, kRequest2);
        EXPECT_EQ(d.chunks[3].bytes, kAnswer2);
        EXPECT_EQ(d.chunks[3].time, 4'000'000);
        EXPECT_TRUE(d.remarks.empty()) << all_of(d.remarks);
    }
    std::string rest = file.str().substr(16);
    std::FILE* stream = fmemopen(rest.data(), rest.size(), "rb");
    auto piped = pcap_source_from_stream(file.str().substr(0, 16), stream, true, "-");
    ASSERT_TRUE(piped.ok());
    const Drained d = drain(**piped);
    EXPECT_EQ(d.chunks.size(), 2U);
    ASSERT_TRUE(d.error);
    EXPECT_TRUE(d.error->to_string().starts_with("-: packet 3: ")) << d.error->to_string();
}

// mergecap's own output: an Ethernet capture and a serial one merged into one file.
TEST(Pcapng, MergecapOfAnEthernetAndASerialCapture) {
    ASSERT_EQ(std::system("which mergecap >/dev/null 2>&1"), 0)
        << "mergecap is missing: install it (Debian: apt-get install tshark)";
    TempDir dir;
    const std::string ethernet = dir.write(
        "eth.pcap", pcap_file(1, {{kT0, eth_tcp(40000, 502, kRequest, 1)},
                                  {kT0 + 40 * kMs, eth_tcp(502, 40000, kAnswer, 1)}}));
    const std::string serial = dir.write(
        "serial.pcap", pcap_file(kUser0, {{kT0 + 20 * kMs, kRequest2}, {kT0 + 60 * kMs, kAnswer2}}));
    const std::string merged = dir.file("merged.pcapng");
    ASSERT_EQ(std::system(("mergecap -F pcapng -w '" + merged + "' '" + ethernet + "' '" + serial +
                           "' 2>/dev/null")
                              .c_str()),
              0);
    auto source = open_source(merged, InputFormat::automatic);
    ASSERT_TRUE(source.ok()) << source.error().to_string();
    const Drained d = drain(**source);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 4U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_EQ(d.chunks[1].bytes, kRequest2);
    EXPECT_EQ(d.chunks[1].time, kT0 + 20 * kMs);
    EXPECT_EQ(d.chunks[2].bytes, kAnswer);
    EXPECT_EQ(d.chunks[3].bytes, kAnswer2);
}

// What libpcap reads, rtuscope's reader reads alike: time units, offsets, byte orders,
// several sections, obsolete packet blocks, blocks it does not know.
TEST(Pcapng, TheOwnReaderReadsWhatLibpcapReads) {
    struct Case {
        const char* name;
        std::string file;
    };
    std::vector<Case> cases;
    for (const bool big : {false, true}) {
        Pcapng ns(big);
        ns.interface(static_cast<std::uint16_t>(kUser0), 9)  // nanoseconds
            .packet(0, static_cast<std::uint64_t>(kT0 + 123), kRequest)
            .block(0x0BAD, "custom block")
            .packet(0, static_cast<std::uint64_t>(kT0 + 5 * kMs + 7), kAnswer);
        cases.push_back({big ? "ns, big-endian" : "ns", ns.str()});
    }
    Pcapng binary;
    binary.interface(static_cast<std::uint16_t>(kUser0), 0x80 | 20)  // 2^-20 s
        .packet(0, (std::uint64_t{1'763'798'400} << 20) + (1U << 19), kRequest);
    cases.push_back({"binary", binary.str()});
    Pcapng offset;
    offset.interface(static_cast<std::uint16_t>(kUser0), {}, 1'700'000'000)
        .packet(0, 63'798'400'500'000, kRequest);
    cases.push_back({"offset", offset.str()});
    Pcapng sections;
    sections.interface(static_cast<std::uint16_t>(kUser0))
        .packet(0, 1'763'798'400'000'000, kRequest)
        .section()
        .interface(static_cast<std::uint16_t>(kUser0), 3)  // milliseconds
        .obsolete_packet(0, 1'763'798'400'020, kAnswer)
        .block(5, std::string(8, '\0'));  // interface statistics
    cases.push_back({"sections", sections.str()});
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        const Drained libpcap = read(c.file);
        auto own = pcapng_source_from_memory(c.file, "own.pcapng");
        ASSERT_TRUE(own.ok()) << own.error().to_string();
        const Drained mine = drain(**own);
        ASSERT_FALSE(libpcap.error) << libpcap.error->to_string();
        ASSERT_FALSE(mine.error) << mine.error->to_string();
        ASSERT_EQ(mine.chunks.size(), libpcap.chunks.size());
        ASSERT_FALSE(mine.chunks.empty());
        for (std::size_t i = 0; i < mine.chunks.size(); ++i) {
            EXPECT_EQ(mine.chunks[i].bytes, libpcap.chunks[i].bytes) << i;
            EXPECT_EQ(mine.chunks[i].time, libpcap.chunks[i].time) << i;
        }
        EXPECT_EQ(mine.remarks, libpcap.remarks);
    }
    // The times as written.
    auto ns = pcapng_source_from_memory(cases[0].file, "ns.pcapng");
    ASSERT_TRUE(ns.ok());
    const Drained d = drain(**ns);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].time, kT0 + 123);
    EXPECT_EQ(d.chunks[1].time, kT0 + 5 * kMs + 7);
    auto binary_source = pcapng_source_from_memory(cases[2].file, "b.pcapng");
    ASSERT_TRUE(binary_source.ok());
    EXPECT_EQ(drain(**binary_source).chunks[0].time, kT0 + 500 * kMs);
    auto offset_source = pcapng_source_from_memory(cases[3].file, "o.pcapng");
    ASSERT_TRUE(offset_source.ok());
    EXPECT_EQ(drain(**offset_source).chunks[0].time, kT0 + 500 * kMs);
}

// A simple packet block has no time and takes interface 0's snap length.
TEST(Pcapng, SimplePacketBlocks) {
    Pcapng file;
    file.interface(static_cast<std::uint16_t>(kUser0), {}, {}, 8)
        .simple_packet(kRequest)
        .simple_packet(kAnswer);  // 9 bytes, 8 kept
    auto own = pcapng_source_from_memory(file.str(), "spb.pcapng");
    ASSERT_TRUE(own.ok()) << own.error().to_string();
    const Drained d = drain(**own);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_EQ(d.chunks[0].time, kNoTime);
    EXPECT_EQ(d.chunks[1].bytes, first(kAnswer, 8));
    EXPECT_EQ(d.chunks[1].bytes_not_captured, 1U);
}

// Broken files: each length is checked against its block; an error names the block's
// place in the file and comes after the packets before it.
TEST(Pcapng, BrokenBlocksAreErrorsAfterThePacketsBefore) {
    const auto with_good_packet = [] {
        Pcapng file;
        file.interface(static_cast<std::uint16_t>(kUser0)).packet(0, 1000, kRequest);
        return file;
    };
    struct Case {
        const char* name;
        std::string file;
        std::string error;
    };
    std::vector<Case> cases;
    {
        Pcapng file = with_good_packet();
        std::string s = file.str() + file.str().substr(48, 40);  // the packet again
        s[s.size() - 4] = 36;                                    // its trailer
        cases.push_back({"trailer", s,
                         "pcapng block at byte 88: its lengths disagree (40 at its start, 36 at "
                         "its end)"});
    }
    {
        Pcapng file = with_good_packet();
        std::string body;
        put32(body, 0);
        put32(body, 0);
        put32(body, 0);
        put32(body, 200);  // captured: past the block
        put32(body, 200);
        body += "12345678";
        file.block(6, body);
        cases.push_back({"captured", file.str(),
                         "pcapng block at byte 88: packet 2: 200 bytes captured run past its "
                         "block"});
    }
    {
        Pcapng file = with_good_packet();
        file.packet(3, 2000, kAnswer);
        cases.push_back({"interface", file.str(),
                         "pcapng block at byte 88: packet 2: interface 3 was not described "
                         "before it"});
    }
    {
        Pcapng file = with_good_packet();
        std::string s = file.str();
        put32(s, 6);
        put32(s, 30);  // not a multiple of 4
        s += std::string(22, '\0');
        cases.push_back({"length", s,
                         "pcapng block at byte 88: block length 30 (a multiple of 4 from 12 to "
                         "16777216 bytes)"});
    }
    {
        Pcapng file = with_good_packet();
        file.packet(0, ~std::uint64_t{0}, kAnswer);
        cases.push_back({"time", file.str(), "pcapng block at byte 88: packet 2: timestamp out of range"});
    }
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        auto own = pcapng_source_from_memory(c.file, "bad.pcapng");
        ASSERT_TRUE(own.ok()) << own.error().to_string();
        const Drained d = drain(**own);
        ASSERT_EQ(d.chunks.size(), 1U);
        ASSERT_TRUE(d.error);
        EXPECT_EQ(d.error->to_string(), std::string("bad.pcapng: ") + c.error);
    }
    auto not_pcapng = pcapng_source_from_memory(pcap_file(kUser0, {{kT0, kRequest}}), "x.pcap");
    ASSERT_FALSE(not_pcapng.ok());
    EXPECT_EQ(not_pcapng.error().to_string(),
              "x.pcap: pcapng block at byte 0: the file does not start with a section header "
              "block");
}

// A file cut off inside a block reads as far as it goes, as libpcap's are.
TEST(Pcapng, AFileCutOffInItsLastBlock) {
    const std::string file = mixed_pcapng();
    for (const std::size_t cut : {std::size_t{3}, std::size_t{40}}) {
        SCOPED_TRACE(cut);
        auto own = pcapng_source_from_memory(file.substr(0, file.size() - cut), "cut.pcapng");
        ASSERT_TRUE(own.ok());
        const Drained d = drain(**own);
        EXPECT_FALSE(d.error);
        EXPECT_EQ(d.chunks.size(), 3U);
        ASSERT_FALSE(d.remarks.empty());
        EXPECT_EQ(d.remarks[0],
                  "the file ends inside packet 5 (cut off before it was complete); 4 packets read");
    }
}

// Interfaces are bounded: a crafted file cannot grow the table without end.
TEST(Pcapng, InterfacesAreBounded) {
    Pcapng file;
    for (std::size_t i = 0; i <= 65536; ++i) file.interface(static_cast<std::uint16_t>(kUser0));
    auto own = pcapng_source_from_memory(file.str(), "many.pcapng");
    ASSERT_FALSE(own.ok());
    EXPECT_EQ(own.error().to_string(),
              fmt::format("many.pcapng: pcapng block at byte {}: more than 65536 interfaces in one "
                          "section",
                          28 + 65536 * 20));
}

// A pcapng file whose interfaces all carry something else is refused, as a pcap is.
TEST(Pcapng, NoInterfaceCarriesRtu) {
    Pcapng file;
    file.interface(105).interface(127).packet(0, 1000, Bytes(30, 0));
    auto source = source_from_memory(file.str(), "wifi.pcapng", InputFormat::automatic);
    ASSERT_FALSE(source.ok());
    EXPECT_EQ(source.error().to_string(),
              "wifi.pcapng: link types 105, 127 are not one rtuscope reads (252, 250, 147-162, "
              "Ethernet/IP with Modbus RTU over TCP/UDP)");
}

// --- TCP streams ---------------------------------------------------------------------------

TEST(PcapTcp, AFrameSplitOverTwoSegmentsIsOneFrame) {
    const std::string file = pcap_file(1, {{kT0, eth_tcp(40000, 502, first(kRequest, 5), 1)},
                                           {kT0 + kMs, eth_tcp(40000, 502, from(kRequest, 5), 6)},
                                           {kT0 + 20 * kMs, eth_tcp(502, 40000, kAnswer, 1)}});
    const Drained d = read(file);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_TRUE(d.chunks[0].whole_frame);
    EXPECT_EQ(d.chunks[0].time, kT0);
    EXPECT_EQ(d.chunks[0].channel, "master");
    EXPECT_EQ(d.chunks[1].bytes, kAnswer);
    const Decoded out = decode(file);
    ASSERT_EQ(out.records.size(), 2U);
    EXPECT_EQ(out.records[1].request_number, 1U);
    EXPECT_EQ(out.totals.invalid, 0U);
}

// Segments sent again are read once: whole ones, and ones that carry old bytes and new.
TEST(PcapTcp, RetransmissionsAreNotDoubled) {
    const Bytes two = concat({kRequest2, kRequest});
    const std::string file =
        pcap_file(1, {{kT0, eth_tcp(40000, 502, kRequest, 1)},
                      {kT0 + 200 * kMs, eth_tcp(40000, 502, kRequest, 1)},  // again
                      {kT0 + 300 * kMs, eth_tcp(502, 40000, kAnswer, 1)},
                      {kT0 + 400 * kMs, eth_tcp(40000, 502, first(kRequest2, 3), 9)},
                      // the same 3 bytes again, and the rest, and another request
                      {kT0 + 600 * kMs, eth_tcp(40000, 502, two, 9)}});
    const Drained d = read(file);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 4U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_EQ(d.chunks[1].bytes, kAnswer);
    EXPECT_EQ(d.chunks[2].bytes, kRequest2);
    EXPECT_EQ(d.chunks[2].time, kT0 + 400 * kMs);  // where its first byte came
    EXPECT_EQ(d.chunks[3].bytes, kRequest);
    EXPECT_EQ(d.chunks[3].time, kT0 + 600 * kMs);
    EXPECT_TRUE(has_remark(d.remarks,
                           "skipped 1 of 5 packets: TCP retransmissions (their bytes read once)"))
        << all_of(d.remarks);
}

// A segment that comes before the one in front of it waits for it.
TEST(PcapTcp, SegmentsOutOfOrder) {
    const Drained d = read(pcap_file(1, {{kT0 - kMs, eth_tcp(40000, 502, {}, 0, kSyn)},
                                         {kT0, eth_tcp(40000, 502, from(kRequest, 4), 5)},
                                         {kT0 + kMs, eth_tcp(40000, 502, first(kRequest, 4), 1)},
                                         {kT0 + 2 * kMs, eth_tcp(40000, 502, kRequest2, 9)}}));
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_EQ(d.chunks[0].time, kT0 + kMs);
    EXPECT_EQ(d.chunks[1].bytes, kRequest2);
}

// A frame and the start of the next in one segment, its rest and another frame in the
// next: three frames; the one that began after another in its segment is placed after it.
TEST(PcapTcp, AFrameAndAHalfASegment) {
    const std::string file =
        pcap_file(1, {{kT0, eth_tcp(40000, 502, concat({kRequest, first(kRequest2, 3)}), 1)},
                      {kT0 + 50 * kMs, eth_tcp(40000, 502, concat({from(kRequest2, 3), kRequest}), 12)}});
    const Drained d = read(file);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 3U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_TRUE(d.chunks[0].whole_frame);
    EXPECT_FALSE(d.chunks[0].time_estimated);
    EXPECT_EQ(d.chunks[1].bytes, kRequest2);
    EXPECT_TRUE(d.chunks[1].time_estimated);
    EXPECT_EQ(d.chunks[1].time, kT0);
    EXPECT_EQ(d.chunks[2].bytes, kRequest);
    EXPECT_EQ(d.chunks[2].time, kT0 + 50 * kMs);
    const Decoded out = decode(file);
    ASSERT_EQ(out.records.size(), 3U);
    EXPECT_EQ(out.records[1].frame.bytes, kRequest2);
    EXPECT_EQ(out.records[1].frame.start, out.records[0].frame.end);
    EXPECT_EQ(out.records[1].frame.silence_before, kNoTime);
    EXPECT_EQ(out.totals.invalid, 0U);
    EXPECT_TRUE(out.remarks.empty()) << all_of(out.remarks);
}

// Two connections at once, each splitting its frames: each stream is put together on its
// own. The second's frame is whole first; the first's, begun before it, comes after it.
TEST(PcapTcp, TwoConnectionsAtOnce) {
    const Drained d = read(pcap_file(1, {{kT0, eth_tcp(40000, 502, first(kRequest, 2), 1)},
                                         {kT0 + 1000, eth_tcp(40001, 502, first(kRequest2, 6), 1)},
                                         {kT0 + 2000, eth_tcp(40001, 502, from(kRequest2, 6), 7)},
                                         {kT0 + 3000, eth_tcp(40000, 502, from(kRequest, 2), 3)}}));
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest2);
    EXPECT_EQ(d.chunks[0].time, kT0 + 1000);
    EXPECT_FALSE(d.chunks[0].time_estimated);
    EXPECT_EQ(d.chunks[1].bytes, kRequest);
    // Placed after the frame before it: the input's time never goes back.
    EXPECT_EQ(d.chunks[1].time, kT0 + 1000);
    EXPECT_TRUE(d.chunks[1].time_estimated);
}

// A connection's bytes start after its SYN; at its FIN what is left of a frame goes out.
TEST(PcapTcp, SynAndFin) {
    const Decoded out = decode(pcap_file(
        1, {{kT0, eth_tcp(40000, 502, {}, 1000, kSyn)},
            {kT0 + kMs, eth_tcp(40000, 502, kRequest, 1001)},
            {kT0 + 2 * kMs, eth_tcp(40000, 502, first(kRequest2, 4), 1009)},
            {kT0 + 3 * kMs, eth_tcp(40000, 502, {}, 1013, kFin)}}));
    ASSERT_EQ(out.records.size(), 2U);
    EXPECT_EQ(out.records[0].frame.bytes, kRequest);
    EXPECT_EQ(out.records[1].frame.bytes, first(kRequest2, 4));
    EXPECT_NE(out.records[1].kind, Kind::request);
}

// Segments that came early are held up to a bound; past it the missing bytes are given
// up, the frames after them read, and a remark says so.
TEST(PcapTcp, EarlySegmentsAreBounded) {
    // The segment after the SYN never comes; the ones after it hold 70 KiB of requests.
    std::vector<Packet> packets = {{kT0 - kMs, eth_tcp(40000, 502, {}, 0, kSyn)}};
    constexpr std::size_t kCount = 70 * 1024 / 8;
    for (std::size_t i = 0; i < kCount; ++i) {
        packets.push_back(
            {kT0 + static_cast<Nanos>(i) * kMs,
             eth_tcp(40000, 502, kRequest, static_cast<std::uint32_t>(9 + 8 * i))});
    }
    const Drained d = read(pcap_file(1, packets));
    ASSERT_FALSE(d.error);
    EXPECT_EQ(d.chunks.size(), kCount);
    EXPECT_TRUE(std::all_of(d.chunks.begin(), d.chunks.end(),
                            [](const Chunk& c) { return c.bytes == kRequest; }));
    EXPECT_TRUE(has_remark(d.remarks,
                           "TCP segments that came early reached the bound of 64 KiB a stream or "
                           "4 MiB in all 1 times: the bytes before them were given up for lost"))
        << all_of(d.remarks);
    EXPECT_TRUE(has_remark(d.remarks,
                           "TCP streams miss bytes the capture did not see in 1 places (8 bytes): "
                           "the bytes around them were framed as they were"))
        << all_of(d.remarks);
}

// More flows at once than the table keeps: the least recently active are forgotten,
// what they held handed on, and a remark says so.
TEST(PcapTcp, FlowsAreBounded) {
    std::vector<Packet> packets;
    constexpr std::size_t kFlows = 4096 + 10;
    for (std::size_t i = 0; i < kFlows; ++i) {
        packets.push_back({kT0 + static_cast<Nanos>(i) * 1000,
                           eth_tcp(static_cast<std::uint16_t>(10000 + i), 502,
                                   concat({kRequest, first(kRequest2, 4)}), 1)});
    }
    const Drained d = read(pcap_file(1, packets));
    ASSERT_FALSE(d.error);
    // Each flow's frame, then its half frame, handed on when the flow is forgotten or at
    // the end.
    ASSERT_EQ(d.chunks.size(), 2 * kFlows);
    EXPECT_EQ(std::count_if(d.chunks.begin(), d.chunks.end(),
                            [](const Chunk& c) { return c.bytes == first(kRequest2, 4); }),
              static_cast<std::ptrdiff_t>(kFlows));
    EXPECT_TRUE(has_remark(d.remarks,
                           "more than 4096 TCP and UDP flows at once: 10 still active were "
                           "forgotten, the least recently active first (what they held was framed "
                           "as it was)"))
        << all_of(d.remarks);
}

// --- what is not Modbus RTU ------------------------------------------------------------------

// A TPKT/COTP/S7comm request and its answer on port 102, as an S7 PLC talks.
Bytes s7(bool answer, std::uint8_t sequence) {
    Bytes b = {0x03, 0x00, 0x00, 0x1F, 0x02, 0xF0, 0x80,                      // TPKT, COTP DT
               0x32, static_cast<std::uint8_t>(answer ? 0x03 : 0x01), 0x00, 0x00, 0x00,
               sequence, 0x00, 0x0E, 0x00, 0x00, 0x04, 0x01, 0x12, 0x0A, 0x10, 0x02,
               0x00, 0x10, 0x00, 0x01, 0x84, 0x00, 0x00, 0x00};
    return b;
}

// An EtherNet/IP ListIdentity (command 0x0063), little-endian, on port 44818.
const Bytes kEnip = {0x63, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                     0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};

// A plant's capture: Modbus RTU over TCP (a gateway on port 502) among S7comm and
// EtherNet/IP traffic.
std::string plant_capture() {
    std::vector<Packet> packets;
    Nanos t = kT0;
    std::uint32_t master = 1;
    std::uint32_t slave = 1;
    std::uint32_t plc = 1;
    std::uint32_t hmi = 1;
    for (std::uint8_t i = 0; i < 10; ++i) {
        packets.push_back({t, eth_tcp(40000, 502, kRequest, master)});
        master += 8;
        packets.push_back({t + 2 * kMs, eth_tcp(49500, 102, s7(false, i), hmi)});
        hmi += 31;
        packets.push_back({t + 3 * kMs, eth_tcp(102, 49500, s7(true, i), plc)});
        plc += 31;
        packets.push_back({t + 20 * kMs, eth_tcp(502, 40000, kAnswer, slave)});
        slave += 9;
        t += 100 * kMs;
    }
    packets.push_back({t, ethernet(0x0800, ipv4(17, udp(50000, 44818, kEnip)))});
    return pcap_file(1, packets);
}

TEST(PcapNotRtu, S7AndEtherNetIpAmongRtuOverTcpAreSkippedAndCounted) {
    const std::string file = plant_capture();
    const Decoded out = decode(file);
    ASSERT_FALSE(out.error);
    ASSERT_EQ(out.records.size(), 20U);
    for (const Record& r : out.records) {
        EXPECT_TRUE(r.kind == Kind::request || r.kind == Kind::response) << r.number;
    }
    EXPECT_EQ(out.totals.invalid, 0U);
    EXPECT_EQ(out.totals.crc_bad, 0U);
    EXPECT_EQ(out.totals.noise_runs, 0U);
    EXPECT_EQ(out.totals.unanswered, 0U);
    EXPECT_TRUE(has_remark(out.remarks,
                           "skipped 21 of 41 packets: TCP and UDP payloads that are neither Modbus "
                           "RTU nor Modbus/TCP (ports 102, 44818)"))
        << all_of(out.remarks);
    const std::string stats = stats_text(file);
    EXPECT_NE(stats.find("bus: 20 frames, 170 bytes; 0 invalid"), std::string::npos) << stats;
    EXPECT_EQ(stats.find("crc  bcast"), stats.find("crc  bcast"));  // the table is there
    EXPECT_NE(stats.find("10   10    0       0       0    0"), std::string::npos) << stats;
}

// --- Modbus/TCP ------------------------------------------------------------------------------

// An MBAP header (transaction id, protocol 0, length), the unit id and the PDU.
Bytes mbap(std::uint16_t transaction, const Bytes& unit_and_pdu) {
    Bytes adu = {static_cast<std::uint8_t>(transaction >> 8), static_cast<std::uint8_t>(transaction),
                 0, 0, static_cast<std::uint8_t>(unit_and_pdu.size() >> 8),
                 static_cast<std::uint8_t>(unit_and_pdu.size())};
    adu.insert(adu.end(), unit_and_pdu.begin(), unit_and_pdu.end());
    return adu;
}

// Modbus/TCP is decoded as RTU is, but for its CRC (none): unit id, function, data; each
// answer paired with the request of its transaction id on its connection, however many
// wait at once; the turnaround from packet to packet.
TEST(PcapModbusTcp, FramesArePairedByTransactionId) {
    const Bytes read = {0x11, 0x03, 0x00, 0x6B, 0x00, 0x02};
    const Bytes read_answer = {0x11, 0x03, 0x04, 0x02, 0x2B, 0x00, 0x64};
    const Bytes write = {0x11, 0x06, 0x00, 0x01, 0x00, 0x03};
    const Bytes exception = {0x11, 0x86, 0x02};
    // Two requests in one segment; their answers the other way round, the write's first.
    const Decoded out = decode(pcap_file(
        1, {{kT0, eth_tcp(40000, 502, concat({mbap(7, read), mbap(8, write)}), 1)},
            {kT0 + 3 * kMs, eth_tcp(502, 40000, mbap(8, exception), 1)},
            {kT0 + 5 * kMs, eth_tcp(502, 40000, mbap(7, read_answer), 10)},
            // RTU over TCP on another connection stays as it is.
            {kT0 + 6 * kMs, eth_tcp(40001, 502, kRequest, 1)},
            {kT0 + 9 * kMs, eth_tcp(502, 40001, kAnswer, 1)}}));
    ASSERT_FALSE(out.error);
    ASSERT_EQ(out.records.size(), 6U);
    const Record& r1 = out.records[0];
    const Record& w1 = out.records[1];
    const Record& w2 = out.records[2];
    const Record& r2 = out.records[3];
    EXPECT_EQ(r1.frame.transport, Transport::tcp);
    EXPECT_EQ(r1.frame.mbap.transaction, 7U);
    EXPECT_EQ(r1.frame.bytes, read);
    EXPECT_EQ(r1.frame.slave(), 0x11);
    EXPECT_EQ(r1.frame.crc.status, CrcStatus::none);
    EXPECT_EQ(r1.kind, Kind::request);
    EXPECT_EQ(r1.decoded.summary, "0x006B x2");
    EXPECT_EQ(w1.kind, Kind::request);
    EXPECT_EQ(w1.frame.mbap.transaction, 8U);
    EXPECT_EQ(w2.kind, Kind::exception);
    EXPECT_EQ(w2.request_number, w1.number);
    EXPECT_EQ(w2.latency, 3 * kMs);
    EXPECT_EQ(r2.kind, Kind::response);
    EXPECT_EQ(r2.request_number, r1.number);
    EXPECT_EQ(r2.latency, 5 * kMs);
    EXPECT_EQ(r2.decoded.summary, "2 registers: 0x022B 0x0064");
    EXPECT_TRUE(r2.notes.empty());
    EXPECT_EQ(out.records[4].frame.transport, Transport::rtu);
    EXPECT_EQ(out.records[4].frame.bytes, kRequest);
    EXPECT_EQ(out.records[5].request_number, out.records[4].number);
    EXPECT_EQ(out.totals.requests, 3U);
    EXPECT_EQ(out.totals.responses, 2U);
    EXPECT_EQ(out.totals.exceptions, 1U);
    EXPECT_EQ(out.totals.invalid, 0U);
    EXPECT_EQ(out.totals.crc_bad, 0U);
    EXPECT_EQ(out.totals.unanswered, 0U);
    EXPECT_TRUE(out.remarks.empty()) << all_of(out.remarks);
}

// An ADU split over two segments is one frame; a request whose answer never comes is
// unanswered; an answer on another connection or with another transaction id is none.
TEST(PcapModbusTcp, SplitAdusAndUnansweredRequests) {
    const Bytes read = mbap(1, {0x01, 0x04, 0x00, 0x00, 0x00, 0x01});
    const Bytes answer = mbap(1, {0x01, 0x04, 0x02, 0x00, 0x2A});
    const Decoded out = decode(pcap_file(
        1, {{kT0, eth_tcp(40000, 502, first(read, 5), 1)},
            {kT0 + kMs, eth_tcp(40000, 502, from(read, 5), 6)},
            {kT0 + 2 * kMs, eth_tcp(502, 40001, answer, 1)},  // another connection
            {kT0 + 3 * kMs, eth_tcp(40000, 502, mbap(2, {0x01, 0x04, 0x00, 0x00, 0x00, 0x01}), 13)},
            {kT0 + 4 * kMs, eth_tcp(502, 40000, answer, 1)}}));
    ASSERT_EQ(out.records.size(), 4U);
    EXPECT_EQ(out.records[0].frame.bytes, from(read, 6));
    EXPECT_EQ(out.records[0].kind, Kind::request);
    EXPECT_EQ(out.records[1].kind, Kind::response);
    EXPECT_EQ(out.records[1].request_number, 0U);
    EXPECT_TRUE(out.records[1].notes.has("txn.unsolicited"));
    EXPECT_EQ(out.records[3].request_number, 1U);
    EXPECT_TRUE(out.records[2].notes.has("txn.no_answer"));
    EXPECT_EQ(out.totals.unanswered, 1U);
}

// A request waits for its answer up to the timeout, and until its transaction id comes
// again on its connection.
TEST(PcapModbusTcp, RequestsAreGivenUpOn) {
    const Bytes read = {0x01, 0x03, 0x00, 0x00, 0x00, 0x01};
    const Bytes answer = {0x01, 0x03, 0x02, 0x00, 0x05};
    const Decoded out = decode(pcap_file(
        1, {{kT0, eth_tcp(40000, 502, mbap(1, read), 1)},
            {kT0 + 1500 * kMs, eth_tcp(502, 40000, mbap(1, answer), 1)},  // past 1 s
            {kT0 + 2000 * kMs, eth_tcp(40000, 502, mbap(2, read), 13)},
            {kT0 + 2100 * kMs, eth_tcp(40000, 502, mbap(2, read), 25)},  // tid 2 again
            {kT0 + 2200 * kMs, eth_tcp(502, 40000, mbap(2, answer), 12)}}));
    ASSERT_EQ(out.records.size(), 5U);
    EXPECT_TRUE(out.records[0].notes.has("txn.no_answer"));
    EXPECT_TRUE(out.records[1].notes.has("txn.unsolicited"));
    EXPECT_TRUE(out.records[2].notes.has("txn.no_answer"));
    EXPECT_EQ(out.records[4].request_number, 4U);
    EXPECT_EQ(out.totals.unanswered, 2U);
    EXPECT_EQ(out.totals.unsolicited, 1U);
}

// Without port 502 (a server elsewhere) the transaction id says which is the answer: the
// first frame of a transaction is its request.
TEST(PcapModbusTcp, WithoutPort502TheTransactionIdSaysWhichIsTheAnswer) {
    const Decoded out = decode(pcap_file(
        1, {{kT0, ethernet(0x0800, ipv4(6, tcp(40000, 5020, mbap(3, {0x05, 0x03, 0x00, 0x00, 0x00, 0x01}))))},
            {kT0 + kMs, ethernet(0x0800, ipv4(6, tcp(5020, 40000, mbap(3, {0x05, 0x03, 0x02, 0x00, 0x09})), true))}}));
    ASSERT_EQ(out.records.size(), 2U);
    EXPECT_EQ(out.records[0].kind, Kind::request);
    EXPECT_EQ(out.records[1].kind, Kind::response);
    EXPECT_EQ(out.records[1].request_number, 1U);
    EXPECT_EQ(out.records[1].decoded.summary, "1 register: 0x0009");
}

// In the outputs: JSON Lines says how a frame travelled and its transaction id; the text
// shows the transaction id; CSV's slave is the unit id, its crc empty.
TEST(PcapModbusTcp, Outputs) {
    const std::string file = pcap_file(
        1, {{kT0, eth_tcp(40000, 502, mbap(0x1234, {0x09, 0x03, 0x00, 0x00, 0x00, 0x01}), 1)},
            {kT0 + 2 * kMs, eth_tcp(502, 40000, mbap(0x1234, {0x09, 0x03, 0x02, 0x00, 0x07}), 1)}});
    const auto run = [&](auto make_sink) {
        auto source = source_from_memory(file, "mem.pcap", InputFormat::automatic);
        EXPECT_TRUE(source.ok());
        std::FILE* out = std::tmpfile();
        auto sink = make_sink(out);
        EXPECT_TRUE(run_pipeline(**source, {}, *sink).ok());
        sink.reset();
        std::rewind(out);
        std::string text;
        char buffer[4096];
        for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, out)) > 0;) text.append(buffer, n);
        std::fclose(out);
        return text;
    };
    const std::string jsonl = run([](std::FILE* f) { return make_jsonl_sink(f); });
    EXPECT_NE(jsonl.find(R"("slave":9,"function":3,"kind":"request","crc":"",)"), std::string::npos)
        << jsonl;
    EXPECT_NE(jsonl.find(R"("hex":"090300000001",)"), std::string::npos) << jsonl;
    EXPECT_NE(jsonl.find(R"("transport":"tcp","transaction":4660})"), std::string::npos) << jsonl;
    const std::string csv = run([](std::FILE* f) { return make_csv_sink(f); });
    EXPECT_NE(csv.find(",9,3,response,,1,2.000,Read Holding Registers 1 register: 0x0007,0903020007,,"), std::string::npos)
        << csv;
    const std::string stats = run([](std::FILE* f) { return make_stats_sink(f, StatsFormat::text); });
    EXPECT_NE(stats.find("0 invalid"), std::string::npos) << stats;
    EXPECT_EQ(stats.find("crc error"), std::string::npos) << stats;
}

// 01 03 00 00 00 02 C4 0B reads as an MBAP header too (protocol 0, length 2): the CRC
// says it is RTU.
TEST(PcapNotRtu, AnRtuFrameShapedLikeModbusTcpIsRtu) {
    ASSERT_TRUE(is_modbus_tcp(kRequest));
    const Decoded out = decode(pcap_file(1, {{kT0, eth_tcp(40000, 502, kRequest, 1)}}));
    ASSERT_EQ(out.records.size(), 1U);
    EXPECT_EQ(out.records[0].kind, Kind::request);
}

// A serial gateway's port given with --rtu-port: its payloads are Modbus RTU whatever they
// hold. Told by content, the line noise a gateway forwards is neither RTU nor Modbus/TCP
// and is skipped, though it was on the bus; given the port, it is noise on the bus, and
// the port's side is the slave's.
TEST(PcapNotRtu, ARtuPortTakesPayloadsAsRtuWhateverTheyHold) {
    const Bytes noise = {0x00, 0xFF, 0x13, 0x37, 0x42, 0x99};
    const std::string file =
        pcap_file(1, {{kT0, eth_tcp(4001, 40000, noise, 1)},
                      {kT0 + 20 * kMs, eth_tcp(40000, 4001, kRequest, 1)},
                      {kT0 + 40 * kMs, eth_tcp(4001, 40000, kAnswer, 1 + static_cast<std::uint32_t>(noise.size()))}});
    const Decoded by_content = decode(file);
    ASSERT_EQ(by_content.records.size(), 2U);
    EXPECT_FALSE(by_content.remarks.empty());
    const Decoded told = decode(file, {}, PcapOptions{{4001}});
    ASSERT_EQ(told.records.size(), 3U) << all_of(told.remarks);
    EXPECT_EQ(told.records[0].kind, Kind::noise);
    EXPECT_EQ(told.records[0].frame.bytes, noise);
    EXPECT_EQ(told.records[1].kind, Kind::request);
    EXPECT_EQ(told.records[1].frame.channel, "master");
    EXPECT_EQ(told.records[2].kind, Kind::response);
    EXPECT_EQ(told.records[2].frame.channel, "slave");
    EXPECT_TRUE(told.remarks.empty()) << all_of(told.remarks);
}

// In a flow that carries RTU a frame with a bad CRC is a bad frame, not another protocol.
TEST(PcapNotRtu, ABadFrameInAnRtuFlowIsKept) {
    const Decoded out = decode(pcap_file(1, {{kT0, eth_tcp(40000, 502, kRequest, 1)},
                                             {kT0 + 20 * kMs, eth_tcp(502, 40000, bad_crc(kAnswer), 1)},
                                             {kT0 + 99 * kMs, eth_tcp(40000, 502, bad_crc(kRequest2), 9)}}));
    ASSERT_EQ(out.records.size(), 3U);
    EXPECT_EQ(out.records[1].frame.crc.status, CrcStatus::bad);
    EXPECT_EQ(out.records[2].frame.crc.status, CrcStatus::bad);
    EXPECT_EQ(out.totals.crc_bad, 2U);
    EXPECT_TRUE(out.remarks.empty()) << all_of(out.remarks);
}

// A flow whose first payload is no RTU carries RTU once a payload is whole frames.
TEST(PcapNotRtu, AFlowBecomesRtuOnWholeFrames) {
    // (A bad kRequest would read as a Modbus/TCP header: kRequest2's does not.)
    const Decoded out = decode(pcap_file(1, {{kT0, eth_tcp(40000, 502, bad_crc(kRequest2), 1)},
                                             {kT0 + 100 * kMs, eth_tcp(40000, 502, kRequest, 9)},
                                             {kT0 + 120 * kMs, eth_tcp(502, 40000, kAnswer, 1)}}));
    ASSERT_EQ(out.records.size(), 2U);
    EXPECT_EQ(out.records[0].kind, Kind::request);
    EXPECT_EQ(out.records[1].kind, Kind::response);
    EXPECT_TRUE(has_remark(out.remarks,
                           "skipped 1 of 3 packets: TCP and UDP payloads that are neither Modbus "
                           "RTU nor Modbus/TCP (port 502)"))
        << all_of(out.remarks);
}

TEST(PcapNotRtu, UdpDatagrams) {
    const Bytes mbap = {0x00, 0x01, 0x00, 0x00, 0x00, 0x06, 0x01, 0x03, 0x00, 0x00, 0x00, 0x02};
    const Decoded out = decode(pcap_file(
        1, {{kT0, ethernet(0x0800, ipv4(17, udp(40000, 502, concat({kRequest, kRequest2}))))},
            {kT0 + kMs, ethernet(0x0800, ipv4(17, udp(40000, 502, bad_crc(kRequest))))},
            {kT0 + 2 * kMs, ethernet(0x0800, ipv4(17, udp(40002, 502, mbap)))},
            {kT0 + 3 * kMs, ethernet(0x0800, ipv4(17, udp(40003, 123, Bytes(48, 0x23))))}}));
    ASSERT_EQ(out.records.size(), 4U);
    EXPECT_EQ(out.records[0].frame.bytes, kRequest);
    EXPECT_EQ(out.records[1].frame.bytes, kRequest2);
    EXPECT_EQ(out.records[2].frame.crc.status, CrcStatus::bad);
    EXPECT_EQ(out.records[3].frame.transport, Transport::tcp);  // Modbus/UDP
    EXPECT_EQ(out.records[3].frame.bytes, from(mbap, 6));
    EXPECT_TRUE(has_remark(out.remarks,
                           "skipped 1 of 4 packets: TCP and UDP payloads that are neither Modbus "
                           "RTU nor Modbus/TCP (port 123)"))
        << all_of(out.remarks);
}

std::vector<std::string> split(const std::string& text, char separator) {
    std::vector<std::string> out;
    std::size_t at = 0;
    for (;;) {
        const std::size_t next = text.find(separator, at);
        out.push_back(text.substr(at, next - at));
        if (next == std::string::npos) return out;
        at = next + 1;
    }
}

// Wireshark's Modbus/TCP dissector and rtuscope read captures/pcaps/modbus_tcp.pcap alike:
// the same ADUs, transaction ids, unit ids, function codes and exception codes, and each
// answer Wireshark pairs is paired with the same request.
TEST(PcapModbusTcp, TsharkAgreesOnFramesFunctionsAndPairs) {
    ASSERT_EQ(std::system("which tshark >/dev/null 2>&1"), 0)
        << "tshark is missing: install it (Debian: apt-get install tshark) to check the "
           "Modbus/TCP decoding against Wireshark's";
    const std::string path = RTUSCOPE_SOURCE_DIR "/captures/pcaps/modbus_tcp.pcap";
    std::string out;
    std::FILE* pipe = popen(("tshark -r '" + path +
                             "' -Y mbtcp -T fields -E separator=/t -e frame.number -e "
                             "mbtcp.trans_id -e mbtcp.unit_id -e modbus.func_code -e "
                             "modbus.exception_code -e modbus.request_frame 2>/dev/null")
                                .c_str(),
                            "r");
    ASSERT_NE(pipe, nullptr);
    char buffer[4096];
    for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
    pclose(pipe);
    // One row a packet; a packet of two ADUs lists each field twice, comma-separated.
    struct Adu {
        std::string packet, transaction, unit, function, exception, request_packet;
    };
    std::vector<Adu> adus;
    for (const std::string& row : split(out, '\n')) {
        if (row.empty()) continue;
        const std::vector<std::string> f = split(row, '\t');
        ASSERT_EQ(f.size(), 6U) << row;
        const std::vector<std::string> transactions = split(f[1], ',');
        const std::vector<std::string> units = split(f[2], ',');
        const std::vector<std::string> functions = split(f[3], ',');
        ASSERT_EQ(units.size(), transactions.size()) << row;
        ASSERT_EQ(functions.size(), transactions.size()) << row;
        for (std::size_t i = 0; i < transactions.size(); ++i) {
            // Wireshark keeps one request a packet: it pairs the answers of a packet of
            // two requests only with its last.
            const bool one = transactions.size() == 1;
            adus.push_back({f[0], transactions[i], units[i], functions[i], one ? f[4] : "",
                            one ? f[5] : ""});
        }
    }
    auto source = open_source(path, InputFormat::automatic);
    ASSERT_TRUE(source.ok()) << source.error().to_string();
    CollectingSink collect;
    ASSERT_TRUE(run_pipeline(**source, {}, collect).ok());
    const std::vector<Record>& records = collect.records;
    ASSERT_EQ(records.size(), adus.size()) << out;
    std::size_t pairs = 0;
    for (std::size_t i = 0; i < records.size(); ++i) {
        SCOPED_TRACE("ADU " + std::to_string(i + 1) + " in packet " + adus[i].packet);
        const Record& r = records[i];
        EXPECT_EQ(r.frame.transport, Transport::tcp);
        EXPECT_EQ(std::to_string(r.frame.mbap.transaction), adus[i].transaction);
        EXPECT_EQ(std::to_string(r.frame.slave()), adus[i].unit);
        EXPECT_EQ(std::to_string(r.frame.function() & 0x7FU), adus[i].function);
        if (r.kind == Kind::exception) {
            EXPECT_EQ(std::to_string(r.decoded.exception_code), adus[i].exception);
        } else {
            EXPECT_EQ(adus[i].exception, "");
        }
        if (!adus[i].request_packet.empty()) {
            ASSERT_NE(r.request_number, 0U);
            EXPECT_EQ(adus[r.request_number - 1].packet, adus[i].request_packet);
            ++pairs;
        }
        if (r.request_number == 0) {
            EXPECT_EQ(adus[i].request_packet, "");
        }
    }
    EXPECT_EQ(pairs, 4U);
}

TEST(Mbap, Recognition) {
    const Bytes adu = {0x12, 0x34, 0x00, 0x00, 0x00, 0x06, 0x11, 0x03, 0x00, 0x6B, 0x00, 0x03};
    EXPECT_EQ(mbap_adu_length(adu), 12U);
    EXPECT_TRUE(is_modbus_tcp(adu));
    EXPECT_TRUE(is_modbus_tcp(concat({adu, adu})));
    EXPECT_EQ(mbap_adu_length(first(adu, 8)), 12U);  // the header gives it
    EXPECT_FALSE(is_modbus_tcp(first(adu, 11)));      // the rest has not come
    EXPECT_FALSE(is_modbus_tcp(concat({adu, {0x00}})));
    Bytes other = adu;
    other[3] = 0x01;  // protocol id 1
    EXPECT_EQ(mbap_adu_length(other), 0U);
    other = adu;
    other[5] = 0x01;  // length 1: no function code
    EXPECT_EQ(mbap_adu_length(other), 0U);
    other = adu;
    other[4] = 0x01;  // length 262: past a PDU's 253 bytes
    EXPECT_EQ(mbap_adu_length(other), 0U);
    other = adu;
    other[7] = 0x00;  // function 0
    EXPECT_EQ(mbap_adu_length(other), 0U);
    EXPECT_FALSE(is_modbus_tcp({}));
}

}  // namespace
}  // namespace rtuscope
