// --pcap: the decided frames as a classic pcap file of Wireshark exported PDUs (link type
// 252). Written by hand rather than through pcap_dump so that every write error is seen.
// Tag numbers and layout: Wireshark's epan/exported_pdu.h; the length of a tag counts the
// padding of its value to a multiple of 4 (as Wireshark's own exporter writes it).
#include "output/pcap_writer.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>

#include "util/io_block.hpp"

namespace rtuscope {

namespace {

constexpr std::uint16_t kTagEndOfOpt = 0;
constexpr std::uint16_t kTagDissectorName = 12;  // EXP_PDU_TAG_DISSECTOR_NAME (PROTO_NAME)
constexpr std::uint16_t kTagPortType = 24;
constexpr std::uint16_t kTagSrcPort = 25;
constexpr std::uint16_t kTagDstPort = 26;
// rtuscope's own tag, far above Wireshark's (0-38; Wireshark shows it as an unknown tag),
// so that a frame read back is timed as it was and turnarounds stay what they were: 64
// bits, the frame's duration on the line in nanoseconds, the top bit set when its start
// is an estimate (no silence before it measured).
constexpr std::uint16_t kTagFrameTiming = 0xF2A5;
constexpr std::uint64_t kTimeEstimated = std::uint64_t{1} << 63U;
constexpr std::uint32_t kPortTypeTcp = 2;  // EXP_PDU_PT_TCP
constexpr std::uint32_t kNanosecondMagic = 0xA1B23C4D;
constexpr std::uint32_t kSnapLen = 65535;

void put16be(std::vector<std::uint8_t>& out, std::uint16_t v) {
    out.push_back(static_cast<std::uint8_t>(v >> 8));
    out.push_back(static_cast<std::uint8_t>(v));
}

void put32be(std::vector<std::uint8_t>& out, std::uint32_t v) {
    put16be(out, static_cast<std::uint16_t>(v >> 16));
    put16be(out, static_cast<std::uint16_t>(v));
}

// pcap headers are in the writer's byte order; little-endian is what every reader expects
// from x86 and ARM writers, and writing it explicitly keeps the file the same everywhere.
void put32le(std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void put_tag(std::vector<std::uint8_t>& out, std::uint16_t tag,
             std::span<const std::uint8_t> value) {
    const std::size_t padded = (value.size() + 3) & ~std::size_t{3};
    put16be(out, tag);
    put16be(out, static_cast<std::uint16_t>(padded));
    out.insert(out.end(), value.begin(), value.end());
    out.resize(out.size() + (padded - value.size()), 0);
}

void put_u32_tag(std::vector<std::uint8_t>& out, std::uint16_t tag, std::uint32_t v) {
    put16be(out, tag);
    put16be(out, 4);
    put32be(out, v);
}

}  // namespace

FrameDirection direction_of(const Record& record) {
    switch (record.kind) {
        case Kind::request:
        case Kind::broadcast:
            return FrameDirection::to_slave;
        case Kind::response:
        case Kind::exception:
            return FrameDirection::from_slave;
        case Kind::unknown:
        case Kind::invalid:
        case Kind::noise:
            break;
    }
    switch (record.frame.reading) {
        case Reading::request:
            return FrameDirection::to_slave;
        case Reading::response:
        case Reading::exception:
            return FrameDirection::from_slave;
        case Reading::unknown:
            break;
    }
    // A two-port tap still says which side sent it.
    if (!record.frame.channel.empty()) {
        return record.frame.channel == "master" ? FrameDirection::to_slave : FrameDirection::from_slave;
    }
    return FrameDirection::unclear;
}

Nanos packet_time(const Record& record) {
    if (has_time(record.frame.start)) return record.frame.start;
    if (has_time(record.frame.end)) return record.frame.end;
    return static_cast<Nanos>(record.number) * 1000;
}

bool is_written(const Record& record) {
    // Frames only: noise is none, nor the part of one a stop or a capture's snap length
    // cut off.
    return record.kind != Kind::noise && record.frame.is_frame() &&
           !record.notes.has(note_id::cut_by_stop) && !record.notes.has(note_id::cut_by_snaplen);
}

void append_pcap_packet(std::vector<std::uint8_t>& out, const Record& record) {
    // Modbus RTU for Wireshark's mbrtu dissector; Modbus/TCP, its MBAP header put back in
    // front of the unit id, for mbtcp.
    const bool tcp = record.frame.transport == Transport::tcp;
    const std::string_view name = tcp ? "mbtcp" : "mbrtu";
    put_tag(out, kTagDissectorName,
            std::span(reinterpret_cast<const std::uint8_t*>(name.data()), name.size()));
    // Neither port 502 when the direction is unclear: Wireshark then guesses from the
    // frame's shape, as rtuscope did.
    // Modbus/TCP: the client's port tells the connections apart, whose transaction ids
    // count each on its own.
    constexpr std::uint32_t kClientPorts = 16384;  // 49152-65535
    const auto client = static_cast<std::uint16_t>(
        kMasterPort + (tcp ? record.frame.mbap.connection % kClientPorts : 0));
    std::uint16_t src = client;
    std::uint16_t dst = client;
    switch (direction_of(record)) {
        case FrameDirection::to_slave:
            dst = kModbusPort;
            break;
        case FrameDirection::from_slave:
            src = kModbusPort;
            break;
        case FrameDirection::unclear:
            break;
    }
    put_u32_tag(out, kTagPortType, kPortTypeTcp);
    put_u32_tag(out, kTagSrcPort, src);
    put_u32_tag(out, kTagDstPort, dst);
    if (has_time(record.frame.start) && has_time(record.frame.end) &&
        record.frame.end >= record.frame.start) {
        std::uint64_t timing = static_cast<std::uint64_t>(record.frame.end - record.frame.start);
        if (!has_time(record.frame.silence_before)) timing |= kTimeEstimated;
        put16be(out, kTagFrameTiming);
        put16be(out, 8);
        put32be(out, static_cast<std::uint32_t>(timing >> 32U));
        put32be(out, static_cast<std::uint32_t>(timing));
    }
    put_tag(out, kTagEndOfOpt, {});
    if (tcp) {
        put16be(out, record.frame.mbap.transaction);
        put16be(out, 0);  // protocol id: Modbus
        put16be(out, static_cast<std::uint16_t>(record.frame.bytes.size()));
    }
    out.insert(out.end(), record.frame.bytes.begin(), record.frame.bytes.end());
}

PcapSink::PcapSink(std::FILE* file, std::string path)
    : file_(file),
      path_(std::move(path)),
      // Before any write: stdio's own 4 KiB would make a write() every ~60 packets.
      write_buffer_(give_stdio_buffer(file)) {}

PcapSink::~PcapSink() {
    if (file_ != nullptr) std::fclose(file_);
}

void PcapSink::fail(const char* what, int err) {
    if (!error_)
        error_ = Error{fmt::format("cannot {} the pcap: {}", what, std::strerror(err)), path_};
}

void PcapSink::write(const void* data, std::size_t size) {
    if (error_ || file_ == nullptr) return;
    if (std::fwrite(data, 1, size, file_) != size) fail("write", errno);
}

void PcapSink::begin(const SessionInfo& /*session*/) {}

void PcapSink::record(const Record& record) {
    if (!is_written(record)) return;
    packet_.clear();
    append_pcap_packet(packet_, record);
    const Nanos t = std::max<Nanos>(0, packet_time(record));  // pcap has no negative times
    header_.clear();
    put32le(header_, static_cast<std::uint32_t>(t / kNanosPerSecond));
    put32le(header_, static_cast<std::uint32_t>(t % kNanosPerSecond));
    put32le(header_, static_cast<std::uint32_t>(packet_.size()));
    put32le(header_, static_cast<std::uint32_t>(packet_.size()));
    write(header_.data(), header_.size());
    write(packet_.data(), packet_.size());
    if (!error_) ++packets_;
}

void PcapSink::flush() {
    if (error_ || file_ == nullptr) return;
    if (std::fflush(file_) != 0) fail("write", errno);
}

void PcapSink::end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) {
    if (file_ == nullptr) return;
    flush();
    // fclose reports what the kernel refused last (a full disk shows up here).
    if (std::fclose(file_) != 0) fail("close", errno);
    file_ = nullptr;
}

Status PcapSink::status() const {
    if (error_) return *error_;
    return ok_status();
}

Result<std::unique_ptr<PcapSink>> make_pcap_sink(const std::string& path) {
    std::FILE* file = std::fopen(path.c_str(), "wbe");
    if (file == nullptr) {
        return Error{fmt::format("cannot create the pcap: {}", std::strerror(errno)), path};
    }
    std::unique_ptr<PcapSink> sink(new PcapSink(file, path));
    std::vector<std::uint8_t> header;
    put32le(header, kNanosecondMagic);
    header.push_back(2);  // version 2.4
    header.push_back(0);
    header.push_back(4);
    header.push_back(0);
    put32le(header, 0);  // thiszone
    put32le(header, 0);  // sigfigs
    put32le(header, kSnapLen);
    put32le(header, static_cast<std::uint32_t>(kLinktypeUpperPdu));
    sink->write(header.data(), header.size());
    sink->flush();
    if (Status s = sink->status(); !s) return s.error();
    return sink;
}

}  // namespace rtuscope
