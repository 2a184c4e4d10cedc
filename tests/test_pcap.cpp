// pcap writer and reader: the written file as tshark decodes it, the reader on every link
// type it accepts (files built here byte by byte), damaged files, and the round trip.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "input/pcap.hpp"
#include "input/sources.hpp"
#include "output/pcap_writer.hpp"
#include "output/pcapng_writer.hpp"
#include "pcap_builders.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using namespace test;  // Bytes, with_crc, the pcap builders

constexpr Nanos kT0 = 1'763'798'400'000'000'000;  // 2025-11-22, a whole second
const Nanos kChar = LineSettings{}.char_time();   // 9600 8N1

// --- building records and files -------------------------------------------------------

Record make_record(std::uint64_t number, Kind kind, Bytes bytes, Nanos start,
                   Reading reading = Reading::unknown) {
    Record r;
    r.number = number;
    r.kind = kind;
    r.frame.bytes = std::move(bytes);
    r.frame.start = start;
    if (has_time(start)) r.frame.end = start + static_cast<Nanos>(r.frame.bytes.size()) * kChar;
    r.frame.crc = check_crc(r.frame.bytes);
    r.frame.cls = kind == Kind::noise     ? RecordClass::noise
                  : kind == Kind::invalid ? RecordClass::invalid
                                          : RecordClass::frame;
    r.frame.reading = reading;
    return r;
}

// FC03 request and answer, an exception, a bad-CRC request, FC05 request and its echo
// (which only the ports tell apart).
std::vector<Record> sample_records() {
    Bytes bad = with_crc({0x01, 0x03, 0x00, 0x10, 0x00, 0x01});
    bad[7] ^= 0xFF;
    const Bytes fc05 = with_crc({0x02, 0x05, 0x00, 0x01, 0xFF, 0x00});
    return {
        make_record(1, Kind::request, with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02}), kT0),
        make_record(2, Kind::response, with_crc({0x01, 0x03, 0x04, 0x00, 0x01, 0x00, 0x02}),
                    kT0 + 20 * test::kMs),
        make_record(3, Kind::exception, with_crc({0x01, 0x83, 0x02}), kT0 + 100 * test::kMs),
        make_record(4, Kind::invalid, bad, kT0 + 200 * test::kMs, Reading::request),
        make_record(5, Kind::request, fc05, kT0 + 300 * test::kMs),
        make_record(6, Kind::response, fc05, kT0 + 320 * test::kMs),
    };
}

std::string write_records(const std::string& path, const std::vector<Record>& records) {
    auto sink = make_pcap_sink(path);
    EXPECT_TRUE(sink.ok()) << sink.error().to_string();
    if (!sink.ok()) return {};
    (*sink)->begin({});
    for (const Record& r : records) (*sink)->record(r);
    (*sink)->end({}, {});
    EXPECT_TRUE((*sink)->status().ok());
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

Drained read_memory(const std::string& content) {
    auto source = pcap_source_from_memory(content, "mem.pcap");
    EXPECT_TRUE(source.ok()) << source.error().to_string();
    if (!source.ok()) return {};
    EXPECT_EQ((*source)->info().format, "pcap");
    EXPECT_TRUE((*source)->info().timed);
    EXPECT_TRUE((*source)->info().chunk_time_is_start);
    Drained d = drain(**source);
    for (const Chunk& c : d.chunks) EXPECT_TRUE(c.whole_frame);
    return d;
}

const Bytes kRequest = with_crc({0x01, 0x03, 0x00, 0x00, 0x00, 0x02});
const Bytes kAnswer = with_crc({0x01, 0x03, 0x04, 0x00, 0x01, 0x00, 0x02});

// --- tshark -----------------------------------------------------------------------------

std::string run(const std::string& command) {
    std::string out;
    std::FILE* pipe = popen(command.c_str(), "r");
    if (pipe == nullptr) return out;
    std::array<char, 4096> buf{};
    std::size_t n = 0;
    while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) out.append(buf.data(), n);
    pclose(pipe);
    return out;
}

std::vector<std::vector<std::string>> tsv(const std::string& text) {
    std::vector<std::vector<std::string>> rows;
    std::istringstream lines(text);
    std::string line;
    while (std::getline(lines, line)) {
        std::vector<std::string> fields;
        std::size_t at = 0;
        for (;;) {
            const std::size_t tab = line.find('\t', at);
            fields.push_back(line.substr(at, tab - at));
            if (tab == std::string::npos) break;
            at = tab + 1;
        }
        rows.push_back(std::move(fields));
    }
    return rows;
}

TEST(PcapWriter, TsharkDecodesFunctionCodesDirectionsAndBadCrc) {
    ASSERT_EQ(std::system("which tshark >/dev/null 2>&1"), 0)
        << "tshark is missing: install it (Debian: apt-get install tshark) to check the pcap "
           "output against Wireshark's Modbus RTU dissector";
    TempDir dir;
    const std::string path = dir.file("out.pcap");
    write_records(path, sample_records());
    // The options pcap_writer.hpp documents: 502 as the mbrtu port (query/response from the
    // ports) and CRC checking.
    const std::string out =
        run("tshark -r '" + path +
            "' -o mbrtu.tcp.port:502 -o mbrtu.crc_verification:TRUE -T fields -E "
            "separator=/t -e frame.protocols -e mbrtu.unit_id -e modbus.func_code -e "
            "modbus.exception_code -e mbrtu.crc16.status -e modbus.request_frame -e "
            "_ws.col.Info 2>/dev/null");
    const auto rows = tsv(out);
    ASSERT_EQ(rows.size(), 6U) << out;
    struct Want {
        const char* unit;
        const char* func;
        const char* exception;
        const char* crc;  // 1 good, 0 bad
        const char* request_frame;
        const char* direction;
    };
    const Want want[] = {
        {"1", "3", "", "1", "", "Query"},     {"1", "3", "", "1", "1", "Response"},
        {"1", "3", "2", "1", "", "Response"}, {"1", "3", "", "0", "", "Query"},
        {"2", "5", "", "1", "", "Query"},     {"2", "5", "", "1", "5", "Response"},
    };
    for (std::size_t i = 0; i < rows.size(); ++i) {
        SCOPED_TRACE("packet " + std::to_string(i + 1) + ": " + out);
        ASSERT_EQ(rows[i].size(), 7U);
        EXPECT_EQ(rows[i][0], "exported_pdu:mbrtu:modbus");
        EXPECT_EQ(rows[i][1], want[i].unit);
        EXPECT_EQ(rows[i][2], want[i].func);
        EXPECT_EQ(rows[i][3], want[i].exception);
        EXPECT_EQ(rows[i][4], want[i].crc);
        EXPECT_EQ(rows[i][5], want[i].request_frame);
        EXPECT_TRUE(rows[i][6].find(want[i].direction) != std::string::npos) << rows[i][6];
        EXPECT_TRUE(rows[i][6].find("unknown") == std::string::npos) << rows[i][6];
    }
    // Times: the frame starts, to the nanosecond.
    const auto times =
        tsv(run("tshark -r '" + path + "' -T fields -e frame.time_epoch 2>/dev/null"));
    ASSERT_EQ(times.size(), 6U);
    EXPECT_EQ(times[0][0], "1763798400.000000000");
    EXPECT_EQ(times[1][0], "1763798400.020000000");
}

// --- writer -----------------------------------------------------------------------------

TEST(PcapWriter, WritesHeaderAndExportedPduTags) {
    TempDir dir;
    const std::string file = write_records(dir.file("a.pcap"), {sample_records()[0]});
    std::string want;
    put32(want, 0xA1B23C4D);  // nanosecond pcap
    put16(want, 2, false);
    put16(want, 4, false);
    put32(want, 0);
    put32(want, 0);
    put32(want, 65535);
    put32(want, 252);
    put32(want, 1'763'798'400);
    put32(want, 0);
    const std::string tags = std::string("\0\x0C\0\x08mbrtu\0\0\0", 12) +
                             std::string("\0\x18\0\x04\0\0\0\x02", 8) +    // TCP
                             std::string("\0\x19\0\x04\0\0\xC0\x00", 8) +  // 49152
                             std::string("\0\x1A\0\x04\0\0\x01\xF6", 8) +  // 502
                             // rtuscope's timing: 8,333,328 ns, the first frame (no
                             // silence before it: the top bit)
                             std::string("\xF2\xA5\0\x08\x80\0\0\0\0\x7F\x28\x10", 12) +
                             std::string("\0\0\0\0", 4) + str(kRequest);
    put32(want, static_cast<std::uint32_t>(tags.size()));
    put32(want, static_cast<std::uint32_t>(tags.size()));
    want += tags;
    EXPECT_EQ(file, want);
}

TEST(PcapWriter, DirectionFromKindThenReadingThenChannel) {
    auto ports = [](const Record& r) {
        Bytes p;
        append_pcap_packet(p, r);
        return std::pair<int, int>((p[26] << 8) | p[27], (p[34] << 8) | p[35]);
    };
    using P = std::pair<int, int>;
    EXPECT_EQ(ports(make_record(1, Kind::broadcast, kRequest, kT0)), P(49152, 502));
    EXPECT_EQ(ports(make_record(1, Kind::exception, kAnswer, kT0)), P(502, 49152));
    EXPECT_EQ(ports(make_record(1, Kind::invalid, kAnswer, kT0, Reading::response)), P(502, 49152));
    EXPECT_EQ(ports(make_record(1, Kind::unknown, kRequest, kT0, Reading::request)), P(49152, 502));
    Record tapped = make_record(1, Kind::unknown, kRequest, kT0);
    tapped.frame.channel = "master";
    EXPECT_EQ(ports(tapped), P(49152, 502));
    tapped.frame.channel = "slave";
    EXPECT_EQ(ports(tapped), P(502, 49152));
    // Unclear: neither side is 502, so Wireshark guesses from the shape.
    EXPECT_EQ(ports(make_record(1, Kind::unknown, kRequest, kT0)), P(49152, 49152));
}

TEST(PcapWriter, LeavesOutNoiseAndStampsUntimedFramesByNumber) {
    TempDir dir;
    const std::string path = dir.file("b.pcap");
    std::vector<Record> records = {
        make_record(1, Kind::request, kRequest, kNoTime),
        make_record(2, Kind::noise, {0xFF, 0x00}, kNoTime),
        make_record(3, Kind::response, kAnswer, kNoTime),
    };
    auto sink = make_pcap_sink(path);
    ASSERT_TRUE(sink.ok());
    for (const Record& r : records) (*sink)->record(r);
    (*sink)->end({}, {});
    EXPECT_TRUE((*sink)->status().ok());
    EXPECT_EQ((*sink)->packets(), 2U);
    auto source = open_pcap_source(path);
    ASSERT_TRUE(source.ok()) << source.error().to_string();
    const Drained d = drain(**source);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].time, 1000);  // record 1: 1 us
    EXPECT_EQ(d.chunks[1].time, 3000);  // record 3: 3 us
}

TEST(PcapWriter, ReportsCreateAndWriteErrors) {
    auto missing = make_pcap_sink("/no/such/dir/out.pcap");
    ASSERT_FALSE(missing.ok());
    EXPECT_EQ(missing.error().to_string(),
              "/no/such/dir/out.pcap: cannot create the pcap: No such file or directory");
    // /dev/full takes the open and refuses the bytes.
    auto full = make_pcap_sink("/dev/full");
    ASSERT_FALSE(full.ok());
    EXPECT_EQ(full.error().to_string(),
              "/dev/full: cannot write the pcap: No space left on device");
}

// --- reader: link types -----------------------------------------------------------------

TEST(PcapReader, ExportedPdusGiveFramesAndDirections) {
    TempDir dir;
    const std::string file = write_records(dir.file("c.pcap"), sample_records());
    const Drained d = read_memory(file);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 6U);
    EXPECT_EQ(d.chunks[0].channel, "master");
    EXPECT_EQ(d.chunks[1].channel, "slave");
    EXPECT_EQ(d.chunks[2].channel, "slave");
    EXPECT_EQ(d.chunks[3].channel, "master");
    EXPECT_EQ(d.chunks[1].bytes, kAnswer);
    EXPECT_EQ(d.chunks[1].time, kT0 + 20 * test::kMs);
    EXPECT_TRUE(d.remarks.empty());
}

TEST(PcapReader, SkipsExportedPdusForOtherDissectors) {
    Bytes other = {0, 12, 0, 4, 's', 'i', 'p', 0, 0, 0, 0, 0, 'I', 'N', 'V', 'I', 'T', 'E'};
    Bytes mine = {0, 12, 0, 8, 'm', 'b', 'r', 't', 'u', 0, 0, 0, 0, 0, 0, 0};
    mine.insert(mine.end(), kRequest.begin(), kRequest.end());
    const Drained d = read_memory(pcap_file(252, {{kT0, other}, {kT0 + 1000, mine}}));
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 1U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_EQ(d.chunks[0].channel, "");
    EXPECT_EQ(d.chunks[0].time, kT0 + 1000);
    ASSERT_EQ(d.remarks.size(), 1U);
    EXPECT_EQ(d.remarks[0],
              "skipped 1 of 2 packets: exported PDUs for another dissector (\"sip\")");
}

TEST(PcapReader, SkipReasonsAreBoundedAndNamesShownEscaped) {
    // 40 packets for 40 other dissectors, the first named with a newline and an escape:
    // each name is its own reason, and a crafted file could hold millions.
    std::vector<Packet> packets;
    for (int i = 0; i < 40; ++i) {
        const std::string name = i == 0 ? std::string("x\n\x1B[2J") : fmt::format("p{:02}", i);
        Bytes tag = {0, 12, 0, static_cast<std::uint8_t>(name.size())};
        tag.insert(tag.end(), name.begin(), name.end());
        while (tag.size() % 4 != 0) tag.push_back(0);
        tag.insert(tag.end(), {0, 0, 0, 0, 0x01});
        packets.push_back({kT0 + i * 1000, tag});
    }
    const Drained d = read_memory(pcap_file(252, packets));
    ASSERT_FALSE(d.error);
    EXPECT_TRUE(d.chunks.empty());
    ASSERT_EQ(d.remarks.size(), 33U);
    EXPECT_EQ(d.remarks[31],
              "skipped 1 of 40 packets: exported PDUs for another dissector "
              "(\"x\\x0A\\x1B[2J\")");  // sorted after the p.. names
    EXPECT_EQ(d.remarks[32], "skipped 8 of 40 packets: other reasons (more than 32)");
}

TEST(PcapReader, BrokenExportedPduTagsAreAnErrorAfterTheGoodPackets) {
    Bytes good = {0, 12, 0, 8, 'm', 'b', 'r', 't', 'u', 0, 0, 0, 0, 0, 0, 0};
    good.insert(good.end(), kRequest.begin(), kRequest.end());
    const Bytes broken = {0, 12, 0, 40, 'm', 'b'};
    const Drained d = read_memory(pcap_file(252, {{kT0, good}, {kT0, broken}}));
    ASSERT_EQ(d.chunks.size(), 1U);
    ASSERT_TRUE(d.error);
    EXPECT_EQ(d.error->to_string(),
              "mem.pcap: packet 2: exported-PDU tag 12 runs past the packet end");
}

TEST(PcapReader, RtacSerialDropsTheHeaderAndEventsWithoutData) {
    const Bytes header = {0x69, 0x21, 0x0E, 0x80, 0, 0, 0, 5, 0x02, 0x40, 0, 0};
    Bytes data = header;
    data.insert(data.end(), kAnswer.begin(), kAnswer.end());
    const Drained d = read_memory(pcap_file(250, {{kT0, header}, {kT0 + 5000, data}}));
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), 1U);
    EXPECT_EQ(d.chunks[0].bytes, kAnswer);
    EXPECT_EQ(d.chunks[0].channel, "");
    EXPECT_EQ(d.chunks[0].time, kT0 + 5000);
    ASSERT_EQ(d.remarks.size(), 1U);
    EXPECT_EQ(d.remarks[0], "skipped 1 of 2 packets: RTAC serial events without data");
}

TEST(PcapReader, UserLinkTypesHoldTheFrame) {
    for (const std::uint32_t dlt : {147U, 162U}) {
        const Drained d = read_memory(pcap_file(dlt, {{kT0, kRequest}, {kT0 + 7000, kAnswer}}));
        ASSERT_FALSE(d.error);
        ASSERT_EQ(d.chunks.size(), 2U);
        EXPECT_EQ(d.chunks[0].bytes, kRequest);
        EXPECT_EQ(d.chunks[1].bytes, kAnswer);
        EXPECT_EQ(d.chunks[1].time, kT0 + 7000);
    }
}

TEST(PcapReader, EthernetTcpAndUdpPayloadsWithPortDirections) {
    const Bytes arp = ethernet(0x0806, Bytes(28, 0));
    const Drained d = read_memory(
        pcap_file(1, {{kT0, ethernet(0x0800, ipv4(6, tcp(40000, 502, kRequest)))},
                      {kT0 + 1000, ethernet(0x0800, ipv4(6, tcp(502, 40000, {})))},  // a bare ACK
                      {kT0 + 2000, arp},
                      {kT0 + 3000, ethernet(0x0800, ipv4(6, tcp(502, 40000, kAnswer)))},
                      // Padded to 60 bytes: the IP length tells where the datagram ends.
                      {kT0 + 4000, ethernet(0x0800, ipv4(17, udp(5000, 6000, kRequest)))},
                      {kT0 + 5000, ethernet(0x86DD, ipv6(17, udp(502, 5000, kAnswer)))}}));
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 4U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_EQ(d.chunks[0].channel, "master");
    EXPECT_EQ(d.chunks[1].bytes, kAnswer);
    EXPECT_EQ(d.chunks[1].channel, "slave");
    EXPECT_EQ(d.chunks[1].time, kT0 + 3000);
    EXPECT_EQ(d.chunks[2].bytes, kRequest);
    EXPECT_EQ(d.chunks[2].channel, "");
    EXPECT_EQ(d.chunks[3].bytes, kAnswer);
    EXPECT_EQ(d.chunks[3].channel, "slave");
    ASSERT_EQ(d.remarks.size(), 2U);
    EXPECT_EQ(d.remarks[0], "skipped 1 of 6 packets: TCP segments without data");
    EXPECT_EQ(d.remarks[1], "skipped 1 of 6 packets: packets that are not IP (ARP and the like)");
}

TEST(PcapReader, VlanTaggedEthernet) {
    Bytes frame = ethernet(0x8100, {});
    frame.resize(14);
    const Bytes tag = {0x00, 0x05, 0x08, 0x00};
    frame.insert(frame.end(), tag.begin(), tag.end());
    const Bytes ip = ipv4(6, tcp(502, 1234, kAnswer));
    frame.insert(frame.end(), ip.begin(), ip.end());
    const Drained d = read_memory(pcap_file(1, {{kT0, frame}}));
    ASSERT_EQ(d.chunks.size(), 1U);
    EXPECT_EQ(d.chunks[0].bytes, kAnswer);
}

TEST(PcapReader, LinuxCookedAndRawIp) {
    Bytes sll = {0, 0, 0, 1, 0, 6, 2, 0, 0, 0, 0, 1, 0, 0, 0x08, 0x00};
    const Bytes ip = ipv4(6, tcp(1234, 502, kRequest));
    sll.insert(sll.end(), ip.begin(), ip.end());
    Bytes sll2 = {0x08, 0x00, 0, 0, 0, 0, 0, 2, 0, 1, 0, 6, 2, 0, 0, 0, 0, 1, 0, 0};
    sll2.insert(sll2.end(), ip.begin(), ip.end());
    const std::vector<std::pair<std::uint32_t, Bytes>> cases = {
        {113, sll}, {276, sll2}, {101, ip}, {228, ip}, {229, ipv6(6, tcp(1234, 502, kRequest))}};
    for (const auto& [dlt, packet] : cases) {
        SCOPED_TRACE("link type " + std::to_string(dlt));
        const Drained d = read_memory(pcap_file(dlt, {{kT0, packet}}));
        ASSERT_FALSE(d.error) << d.error->to_string();
        ASSERT_EQ(d.chunks.size(), 1U);
        EXPECT_EQ(d.chunks[0].bytes, kRequest);
        EXPECT_EQ(d.chunks[0].channel, "master");
    }
}

TEST(PcapReader, PcapngWithMicrosecondTimestamps) {
    const std::string file =
        pcapng_file(147, {{kT0 + 1'000, kRequest}, {kT0 + 25'000'000, kAnswer}});
    EXPECT_EQ(detect_input_format(file), InputFormat::pcap);
    auto source = source_from_memory(file, "mem.pcapng", InputFormat::automatic);
    ASSERT_TRUE(source.ok()) << source.error().to_string();
    const Drained d = drain(**source);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].time, kT0 + 1'000);
    EXPECT_EQ(d.chunks[1].time, kT0 + 25'000'000);
    EXPECT_EQ(d.chunks[1].bytes, kAnswer);
}

// A pcap's times are Unix time, unless they are too small for it (a pcap written from a
// capture with relative times): the first packet tells, read ahead when the file opens.
// An error in it comes with the first chunk asked for, as any packet's would.
TEST(PcapReader, TheFirstPacketTellsWhatTheTimesAre) {
    auto absolute = pcap_source_from_memory(pcap_file(147, {{kT0, kRequest}}), "a.pcap");
    ASSERT_TRUE(absolute.ok());
    EXPECT_EQ((*absolute)->info().time_base, TimeBase::unix_time);
    EXPECT_EQ(drain(**absolute).chunks.size(), 1U);
    auto relative = pcap_source_from_memory(
        pcap_file(147, {{1'000'000, kRequest}, {2'000'000, kAnswer}}), "r.pcap");
    ASSERT_TRUE(relative.ok());
    EXPECT_EQ((*relative)->info().time_base, TimeBase::relative);
    const Drained d = drain(**relative);
    ASSERT_EQ(d.chunks.size(), 2U);
    EXPECT_EQ(d.chunks[0].bytes, kRequest);
    EXPECT_EQ(d.chunks[0].time, 1'000'000);
    EXPECT_EQ(d.chunks[1].bytes, kAnswer);
    const Bytes broken = {0, 12, 0, 40, 'm', 'b'};
    auto bad = pcap_source_from_memory(pcap_file(252, {{kT0, broken}}), "b.pcap");
    ASSERT_TRUE(bad.ok());
    const Drained e = drain(**bad);
    EXPECT_TRUE(e.chunks.empty());
    ASSERT_TRUE(e.error);
    EXPECT_EQ(e.error->to_string(),
              "b.pcap: packet 1: exported-PDU tag 12 runs past the packet end");
}

TEST(PcapReader, OtherLinkTypesAreRefused) {
    auto source = pcap_source_from_memory(pcap_file(105, {{kT0, kRequest}}), "wifi.pcap");
    ASSERT_FALSE(source.ok());
    EXPECT_EQ(source.error().to_string(),
              "wifi.pcap: link type 105 is not one rtuscope reads (252, 250, 147-162, "
              "Ethernet/IP with Modbus RTU over TCP/UDP)");
}

TEST(PcapReader, NotAPcapFile) {
    auto source = pcap_source_from_memory("hello, world\n", "text.pcap");
    ASSERT_FALSE(source.ok());
    EXPECT_TRUE(source.error().to_string().starts_with(
        "text.pcap: not a pcap or pcapng file rtuscope can read: "))
        << source.error().to_string();
}

// A file cut off inside its last packet (a capture killed, or still being written) reads
// as far as it goes, as tshark reads it, and says where it ends.
TEST(PcapReader, FileCutOffInItsLastPacketGivesThePacketsBefore) {
    std::string file = pcap_file(147, {{kT0, kRequest}, {kT0 + 1000, kAnswer}, {kT0, kRequest}});
    for (const std::size_t cut :
         {std::size_t{3}, kRequest.size() + 4}) {  // in the data, the header
        SCOPED_TRACE(cut);
        const Drained d = read_memory(file.substr(0, file.size() - cut));
        ASSERT_EQ(d.chunks.size(), 2U);
        EXPECT_FALSE(d.error) << d.error->to_string();
        ASSERT_EQ(d.remarks.size(), 1U);
        EXPECT_EQ(d.remarks[0],
                  "the file ends inside packet 3 (cut off before it was complete); 2 packets read");
    }
}

// A broken packet record before the end is an error, after the packets before it.
TEST(PcapReader, BrokenRecordIsAnErrorAfterThePacketsBefore) {
    std::string file = pcap_file(147, {{kT0, kRequest}, {kT0 + 1000, kAnswer}});
    std::string broken = file;
    const std::size_t second = 24 + 16 + kRequest.size();
    broken[second + 8] = '\xFF';  // captured length 0xFF.. bytes: past the snapshot length
    broken[second + 9] = '\xFF';
    broken[second + 10] = '\xFF';
    const Drained d = read_memory(broken);
    ASSERT_EQ(d.chunks.size(), 1U);
    ASSERT_TRUE(d.error);
    EXPECT_TRUE(d.error->to_string().starts_with("mem.pcap: packet 2: ")) << d.error->to_string();
}

// --- detection and opening --------------------------------------------------------------

TEST(PcapSources, DetectedByMagicNumberOnly) {
    EXPECT_EQ(detect_input_format(pcap_file(147, {})), InputFormat::pcap);
    std::string big_endian = "\xA1\xB2\xC3\xD4";
    big_endian += std::string("\x00\x02\x00\x04", 4);
    EXPECT_EQ(detect_input_format(big_endian), InputFormat::pcap);
    EXPECT_EQ(detect_input_format(std::string("\xD4\xC3\xB2\xA1\x07\x00", 6)), InputFormat::raw);
    EXPECT_EQ(detect_input_format(std::string("\x0A\x0D\x0D\x0A\x01\x02", 6)), InputFormat::raw);
    EXPECT_EQ(*parse_input_format("pcap"), InputFormat::pcap);
    EXPECT_STREQ(to_string(InputFormat::pcap), "pcap");
}

TEST(PcapSources, OpenSourceDetectsAFileAndForcedFormatWorks) {
    TempDir dir;
    const std::string path = dir.file("d.pcap");
    write_records(path, sample_records());
    for (const InputFormat format : {InputFormat::automatic, InputFormat::pcap}) {
        auto source = open_source(path, format);
        ASSERT_TRUE(source.ok()) << source.error().to_string();
        EXPECT_EQ((*source)->info().format, "pcap");
        EXPECT_EQ((*source)->info().name, path);
        EXPECT_EQ(drain(**source).chunks.size(), 6U);
    }
    auto missing = open_pcap_source(dir.file("none.pcap"));
    ASSERT_FALSE(missing.ok());
    EXPECT_EQ(missing.error().message, "cannot open: No such file or directory");
}

TEST(PcapSources, StreamWithSniffedHeadReadsOnFromTheRest) {
    TempDir dir;
    const std::string file = write_records(dir.file("e.pcap"), sample_records());
    // As from a pipe: detection took the first bytes, the stream holds the rest.
    for (const std::size_t cut : {std::size_t{0}, std::size_t{10}, file.size()}) {
        std::string rest = file.substr(cut);
        std::FILE* stream = fmemopen(rest.data(), std::max<std::size_t>(rest.size(), 1), "rb");
        if (rest.empty()) std::fgetc(stream);  // fmemopen wants a size; start at its end
        auto source = pcap_source_from_stream(file.substr(0, cut), stream, true, "-");
        ASSERT_TRUE(source.ok()) << source.error().to_string();
        EXPECT_EQ(drain(**source).chunks.size(), 6U) << "cut at " << cut;
    }
}

// --- round trip -------------------------------------------------------------------------

TEST(PcapRoundTrip, RecordsWrittenAndReadBackKeepBytesTimesAndDirections) {
    TempDir dir;
    const std::string path = dir.file("f.pcap");
    const std::vector<Record> records = sample_records();
    write_records(path, records);
    auto source = open_source(path, InputFormat::automatic);
    ASSERT_TRUE(source.ok()) << source.error().to_string();
    const Drained d = drain(**source);
    ASSERT_FALSE(d.error);
    ASSERT_EQ(d.chunks.size(), records.size());
    for (std::size_t i = 0; i < records.size(); ++i) {
        EXPECT_EQ(d.chunks[i].bytes, records[i].frame.bytes);
        EXPECT_EQ(d.chunks[i].time, records[i].frame.start);
        const bool request =
            records[i].kind == Kind::request ||
            (records[i].kind == Kind::invalid && records[i].frame.reading == Reading::request);
        EXPECT_EQ(d.chunks[i].channel, request ? "master" : "slave");
    }

    // And through the pipeline: the same frames, kinds and times come out.
    auto again = open_source(path, InputFormat::automatic);
    ASSERT_TRUE(again.ok());
    test::CollectingSink collect;
    ASSERT_TRUE(run_pipeline(**again, PipelineOptions{}, collect).ok());
    ASSERT_EQ(collect.records.size(), records.size());
    for (std::size_t i = 0; i < records.size(); ++i) {
        SCOPED_TRACE("record " + std::to_string(i + 1));
        EXPECT_EQ(collect.records[i].frame.bytes, records[i].frame.bytes);
        EXPECT_EQ(collect.records[i].kind, records[i].kind);
        EXPECT_EQ(collect.records[i].frame.start, records[i].frame.start);
        EXPECT_EQ(collect.records[i].frame.end, records[i].frame.end);
    }
}

// Every bundled capture decoded with --pcap and the pcap decoded again: the same frames,
// times (start and end), directions, pairs and turnarounds. A pcap carries no noise, so the frames are compared in
// order and a pair by the frames' positions.
struct FrameSeen {
    Bytes bytes;
    Nanos start = kNoTime;
    Kind kind = Kind::noise;
    std::ptrdiff_t request = -1;  // position of the frame it answers, -1 for none
    Nanos latency = kNoTime;
    Nanos end = kNoTime;
};

std::vector<FrameSeen> frames_of(const std::string& path, const std::string& pcap_out) {
    auto source = open_source(path, InputFormat::automatic);
    EXPECT_TRUE(source.ok()) << path;
    if (!source.ok()) return {};
    test::CollectingSink collect;
    std::unique_ptr<PcapSink> pcap;
    std::vector<std::unique_ptr<RecordSink>> sinks;
    if (!pcap_out.empty()) {
        auto made = make_pcap_sink(pcap_out);
        EXPECT_TRUE(made.ok());
        pcap = std::move(*made);
    }
    struct Both final : RecordSink {
        RecordSink* a;
        RecordSink* b;
        void begin(const SessionInfo& s) override {
            a->begin(s);
            if (b) b->begin(s);
        }
        void record(const Record& r) override {
            a->record(r);
            if (b) b->record(r);
        }
        void end(const Totals& t, const std::vector<std::string>& r) override {
            a->end(t, r);
            if (b) b->end(t, r);
        }
    } both;
    both.a = &collect;
    both.b = pcap.get();
    EXPECT_TRUE(run_pipeline(**source, PipelineOptions{}, both).ok()) << path;
    if (pcap) {
        EXPECT_TRUE(pcap->status().ok());
    }
    std::vector<FrameSeen> frames;
    std::vector<std::ptrdiff_t> position(collect.records.size() + 1, -1);
    for (const Record& r : collect.records) {
        if (r.kind == Kind::noise) continue;
        position[r.number] = static_cast<std::ptrdiff_t>(frames.size());
        FrameSeen f{r.frame.bytes, r.frame.start, r.kind, -1, r.latency, r.frame.end};
        if (r.request_number != 0) f.request = position[r.request_number];
        frames.push_back(f);
    }
    return frames;
}

TEST(PcapRoundTrip, EveryBundledCaptureKeepsFramesTimesDirectionsAndPairs) {
    TempDir dir;
    std::size_t captures = 0;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(
             std::filesystem::path(RTUSCOPE_SOURCE_DIR) / "captures")) {
        const std::string ext = entry.path().extension().string();
        if (!entry.is_regular_file() || ext == ".md" || ext == ".toml") continue;
        const std::string path = entry.path().string();
        SCOPED_TRACE(path);
        const std::string pcap = dir.file("round.pcap");
        const std::vector<FrameSeen> before = frames_of(path, pcap);
        const std::vector<FrameSeen> after = frames_of(pcap, "");
        ASSERT_EQ(after.size(), before.size());
        const bool timed = std::any_of(before.begin(), before.end(),
                                       [](const FrameSeen& f) { return has_time(f.start); });
        for (std::size_t i = 0; i < before.size(); ++i) {
            SCOPED_TRACE("frame " + std::to_string(i + 1));
            EXPECT_EQ(after[i].bytes, before[i].bytes);
            EXPECT_EQ(after[i].kind, before[i].kind);
            EXPECT_EQ(after[i].request, before[i].request);
            if (timed) {
                EXPECT_EQ(after[i].start, before[i].start);
                EXPECT_EQ(after[i].end, before[i].end);
                EXPECT_EQ(after[i].latency, before[i].latency);
            }
        }
        ++captures;
    }
    EXPECT_GT(captures, 20U);
}

// tshark and rtuscope read the same pcap alike: every bundled capture written as a pcap
// of one frame a packet (the port tags giving each frame's direction), then read back by
// both. For each packet: the unit id, the CRC verdict, the function code of a frame whose
// CRC checks, the direction of a request or an answer, and for an answer the request it
// answers. Not compared, and why: frames of fewer than 5 bytes and frames to or from
// address 0 (tshark does not dissect them as Modbus RTU); the direction of frames
// rtuscope finds no role for (unknown, invalid);
// the request of an exception (tshark names none), of an answer rtuscope notes as
// answering no request (unsolicited, a duplicate) and of a broken answer. The pcaps
// in captures/pcaps are not of this kind: a SerialPCAP packet holds several frames, which
// tshark reads as one bad frame, and Modbus/TCP is compared by its own test.
TEST(PcapTshark, AgreesWithRtuscopeOnEveryBundledCaptureAsAPcap) {
    ASSERT_EQ(std::system("which tshark >/dev/null 2>&1"), 0) << "tshark is missing";
    std::size_t captures = 0;
    std::size_t answers_compared = 0;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(
             std::filesystem::path(RTUSCOPE_SOURCE_DIR) / "captures")) {
        const std::string ext = entry.path().extension().string();
        if (!entry.is_regular_file() || ext == ".md" || ext == ".toml" ||
            entry.path().parent_path().filename() == "pcaps") {
            continue;
        }
        SCOPED_TRACE(entry.path().string());
        TempDir dir;
        const std::string pcap = dir.file("out.pcap");
        {
            auto source = open_source(entry.path().string(), InputFormat::automatic);
            ASSERT_TRUE(source) << source.error().to_string();
            auto sink = make_pcap_sink(pcap);
            ASSERT_TRUE(sink);
            ASSERT_TRUE(run_pipeline(**source, PipelineOptions{}, **sink));
        }
        auto source = open_source(pcap, InputFormat::pcap);
        ASSERT_TRUE(source) << source.error().to_string();
        CollectingSink read;
        ASSERT_TRUE(run_pipeline(**source, PipelineOptions{}, read));
        const auto rows =
            tsv(run("tshark -r '" + pcap +
                    "' -o mbrtu.tcp.port:502 -o mbrtu.crc_verification:TRUE -T fields -E "
                    "separator=/t -e mbrtu.unit_id -e modbus.func_code -e mbrtu.crc16.status "
                    "-e modbus.request_frame -e _ws.col.Info 2>/dev/null"));
        ASSERT_EQ(rows.size(), read.records.size());
        for (std::size_t i = 0; i < rows.size(); ++i) {
            const Record& r = read.records[i];
            SCOPED_TRACE(fmt::format("packet {}: {}", i + 1, rows[i].back()));
            ASSERT_EQ(rows[i].size(), 5U);
            ASSERT_EQ(r.number, i + 1);  // a record a packet
            // tshark's Modbus RTU dissector leaves a frame of fewer than 5 bytes, and one
            // to or from address 0 (a broadcast, or an answer from nobody), undissected.
            if (r.frame.bytes.size() < 5 || r.frame.slave() == 0) continue;
            EXPECT_EQ(rows[i][0], std::to_string(r.frame.slave()));
            const bool crc_ok = r.frame.crc.status == CrcStatus::ok;
            EXPECT_EQ(rows[i][2], crc_ok ? "1" : "0");
            if (!crc_ok) continue;
            EXPECT_EQ(rows[i][1], std::to_string(r.frame.function() & 0x7F));
            const std::string& info = rows[i][4];
            switch (r.kind) {
                case Kind::request:
                case Kind::broadcast:
                    EXPECT_NE(info.find("Query"), std::string::npos);
                    break;
                case Kind::response:
                case Kind::exception:
                    EXPECT_NE(info.find("Response"), std::string::npos);
                    // tshark names no request frame for an exception.
                    if (r.kind == Kind::response && r.request_number != 0 &&
                        !r.answers_no_request()) {
                        EXPECT_EQ(rows[i][3], std::to_string(r.request_number));
                        ++answers_compared;
                    }
                    break;
                case Kind::unknown:
                case Kind::invalid:
                case Kind::noise:
                    break;
            }
        }
        ++captures;
    }
    EXPECT_GT(captures, 20U);
    EXPECT_GT(answers_compared, 100U);
}

}  // namespace
}  // namespace rtuscope

// --- pcapng writer ----------------------------------------------------------------------

namespace rtuscope {
namespace {

std::string write_pcapng(const std::string& path, const std::vector<Record>& records,
                         const SessionInfo& session) {
    auto sink = make_pcapng_sink(path, "rtuscope 9.9");
    EXPECT_TRUE(sink.ok()) << sink.error().to_string();
    if (!sink.ok()) return {};
    (*sink)->begin(session);
    for (const Record& r : records) (*sink)->record(r);
    (*sink)->end({}, {});
    EXPECT_TRUE((*sink)->status().ok());
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

std::uint32_t le32(const std::string& s, std::size_t at) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(s[at + i]);
    return v;
}

std::uint16_t le16(const std::string& s, std::size_t at) {
    return static_cast<std::uint16_t>(static_cast<std::uint8_t>(s[at]) |
                                      (static_cast<std::uint8_t>(s[at + 1]) << 8));
}

struct Block {
    std::uint32_t type = 0;
    std::string body;
    // Options from `at` in the body: code, value (unpadded), every option padded to 4.
    std::vector<std::pair<std::uint16_t, std::string>> options(std::size_t at) const {
        std::vector<std::pair<std::uint16_t, std::string>> out;
        while (at + 4 <= body.size()) {
            const std::uint16_t code = le16(body, at);
            const std::uint16_t length = le16(body, at + 2);
            at += 4;
            if (code == 0) {
                EXPECT_EQ(length, 0);
                EXPECT_EQ(at, body.size()) << "bytes after opt_endofopt";
                break;
            }
            out.emplace_back(code, body.substr(at, length));
            at += (length + 3U) & ~3U;
        }
        return out;
    }
};

// The blocks of a file, each checked for its lengths (a multiple of 4, the same at both
// ends) and that they fill the file.
std::vector<Block> blocks_of(const std::string& file) {
    std::vector<Block> out;
    for (std::size_t at = 0; at < file.size();) {
        EXPECT_LE(at + 12, file.size());
        const std::uint32_t length = le32(file, at + 4);
        EXPECT_EQ(length % 4, 0U);
        EXPECT_LE(at + length, file.size());
        if (length % 4 != 0 || at + length > file.size() || length < 12) return out;
        EXPECT_EQ(le32(file, at + length - 4), length);
        out.push_back({le32(file, at), file.substr(at + 8, length - 12)});
        at += length;
    }
    return out;
}

TEST(PcapngWriter, BlocksOptionsAndPaddingAsTheSpecificationLaysThem) {
    TempDir dir;
    std::vector<Record> records = sample_records();
    records[0].answer_number = 2;
    records[1].request_number = 1;
    records[1].latency = 11'670'000;
    records[3].notes.add(note_id::crc_mismatch, "CRC BAD (expected 01 02, got 03 04)");
    DecodedValue& voltage = records[1].values.add();
    voltage.name = "voltage";
    voltage.value = "220.5";
    voltage.unit = "V";
    voltage.raw = "0x089D";
    records[5].frame.channel = "slave";  // a second interface, for the tap's other side
    SessionInfo session;
    session.source.name = "line.rtucap";
    session.line.baud = 19200;
    session.baud_origin = BaudOrigin::input;
    const std::string file = write_pcapng(dir.file("a.pcapng"), records, session);
    const std::vector<Block> blocks = blocks_of(file);
    ASSERT_EQ(blocks.size(), 1U + 1U + 5U + 1U + 1U);  // SHB, IDB, 5 EPBs, IDB, EPB

    // Section header: little-endian magic, version 1.0, length unknown, the application.
    EXPECT_EQ(blocks[0].type, 0x0A0D0D0AU);
    EXPECT_EQ(blocks[0].body.substr(0, 16),
              std::string("\x4D\x3C\x2B\x1A\x01\x00\x00\x00", 8) + std::string(8, '\xFF'));
    const auto shb = blocks[0].options(16);
    ASSERT_EQ(shb.size(), 1U);
    EXPECT_EQ(shb[0], std::make_pair(std::uint16_t{4}, std::string("rtuscope 9.9")));

    // Interfaces: link type 252, the input and its line, nanoseconds.
    EXPECT_EQ(blocks[1].type, 1U);
    EXPECT_EQ(le16(blocks[1].body, 0), 252);
    const auto idb = blocks[1].options(8);
    ASSERT_EQ(idb.size(), 3U);
    EXPECT_EQ(idb[0], std::make_pair(std::uint16_t{2}, std::string("line.rtucap")));
    EXPECT_EQ(idb[1], std::make_pair(std::uint16_t{3}, std::string("19200 8N1")));
    EXPECT_EQ(idb[2], std::make_pair(std::uint16_t{9}, std::string("\x09", 1)));
    EXPECT_EQ(blocks[7].type, 1U);
    EXPECT_EQ(blocks[7].options(8)[0].second, "line.rtucap@slave");

    // Packets: the pcap writer's payload, the time in ns, the direction, the comment.
    const std::uint32_t want_interface[] = {0, 0, 0, 0, 0, 1};
    const std::uint32_t want_flags[] = {2, 1, 1, 2, 2, 1};
    const char* want_comment[] = {
        "rtuscope #1 request: answered by #2",
        "rtuscope #2 response: 11.67 ms after #1\nvoltage = 220.5 V (raw 0x089D)",
        "rtuscope #3 exception",
        "rtuscope #4 invalid request\n! frame.crc_mismatch: CRC BAD (expected 01 02, got 03 04)",
        "rtuscope #5 request",
        "rtuscope #6 response",
    };
    for (std::size_t i = 0; i < 6; ++i) {
        SCOPED_TRACE("packet " + std::to_string(i + 1));
        const Block& epb = blocks[i < 5 ? 2 + i : 8];
        EXPECT_EQ(epb.type, 6U);
        EXPECT_EQ(le32(epb.body, 0), want_interface[i]);
        const auto t = static_cast<std::uint64_t>(records[i].frame.start);
        EXPECT_EQ(le32(epb.body, 4), static_cast<std::uint32_t>(t >> 32U));
        EXPECT_EQ(le32(epb.body, 8), static_cast<std::uint32_t>(t));
        std::vector<std::uint8_t> payload;
        append_pcap_packet(payload, records[i]);
        ASSERT_EQ(le32(epb.body, 12), payload.size());
        EXPECT_EQ(le32(epb.body, 16), payload.size());
        EXPECT_EQ(epb.body.substr(20, payload.size()), std::string(payload.begin(), payload.end()));
        const std::size_t padded = (payload.size() + 3) & ~std::size_t{3};
        EXPECT_EQ(epb.body.substr(20 + payload.size(), padded - payload.size()),
                  std::string(padded - payload.size(), '\0'));
        const auto options = epb.options(20 + padded);
        ASSERT_EQ(options.size(), 2U);
        EXPECT_EQ(options[0].first, 2);  // epb_flags
        EXPECT_EQ(le32(options[0].second, 0), want_flags[i]);
        EXPECT_EQ(options[1], std::make_pair(std::uint16_t{1}, std::string(want_comment[i])));
    }
}

// Read back by rtuscope's own reader: the flags give the direction (and win over ports
// that say otherwise, which a closing note tells), rtuscope's own comment is left out
// (decoding gives it anew) and anyone else's is kept; the line comes from the interface.
TEST(PcapngWriter, ReadBackKeepsFlagsLineAndOthersComments) {
    TempDir dir;
    std::vector<Record> records = sample_records();
    records[2].frame.comments = {"the vendor's reset"};
    SessionInfo session;
    session.line = *parse_line_settings("19200 8E1");
    session.baud_origin = BaudOrigin::option;
    std::string file = write_pcapng(dir.file("a.pcapng"), records, session);
    // Packet 5 (a request, outbound) flagged inbound instead: its ports still say to 502.
    const std::string outbound("\x02\x00\x04\x00\x02\x00\x00\x00", 8);
    // The outbound flags of packets 1, 4 and 5.
    std::size_t at = file.find(outbound);
    for (int i = 0; i < 2 && at != std::string::npos; ++i) at = file.find(outbound, at + 1);
    ASSERT_NE(at, std::string::npos);
    file[at + 4] = '\x01';

    auto source = pcap_source_from_memory(file, "a.pcapng");
    ASSERT_TRUE(source.ok()) << source.error().to_string();
    ASSERT_TRUE((*source)->info().line.has_value());
    EXPECT_EQ((*source)->info().line->baud, 19200U);
    EXPECT_EQ((*source)->info().line->format(), "8E1");
    const Drained d = drain(**source);
    ASSERT_FALSE(d.error) << d.error->to_string();
    ASSERT_EQ(d.chunks.size(), 6U);
    const char* want_channel[] = {"master", "slave", "slave", "master", "slave", "slave"};
    for (std::size_t i = 0; i < 6; ++i) {
        SCOPED_TRACE("chunk " + std::to_string(i + 1));
        EXPECT_EQ(d.chunks[i].channel, want_channel[i]);
        EXPECT_EQ(d.chunks[i].time, records[i].frame.start);
        EXPECT_EQ(d.chunks[i].comments,
                  i == 2 ? std::vector<std::string>{"the vendor's reset"}
                         : std::vector<std::string>{});
    }
    ASSERT_EQ(d.remarks.size(), 1U);
    EXPECT_EQ(d.remarks[0],
              "1 of 6 packets: their direction flags disagree with their ports; the flags are "
              "taken");
}

TEST(PcapngWriter, UnwritablePathIsAnErrorNamingTheFile) {
    auto sink = make_pcapng_sink("/no/such/dir/out.pcapng", "rtuscope 9.9");
    ASSERT_FALSE(sink.ok());
    EXPECT_EQ(sink.error().to_string(),
              "/no/such/dir/out.pcapng: cannot create the pcapng: No such file or directory");
}

}  // namespace
}  // namespace rtuscope
