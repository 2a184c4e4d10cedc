// --pcapng. Block and option codes: draft-ietf-opsawg-pcapng, sections 4.1-4.3.
//
//   block:  type (4)  total length (4)  body  total length (4)
//   SHB 0x0A0D0D0A:  magic 0x1A2B3C4D  major 1  minor 0  section length -1 (unknown)
//                    shb_userappl (4)
//   IDB 1:           link type 252  reserved  snap length 0 (none)
//                    if_name (2)  if_description (3)  if_tsresol (9) = 9 (nanoseconds)
//   EPB 6:           interface  time high  time low  captured  length  data (padded)
//                    epb_flags (2)  opt_comment (1) ...
//   option:          code (2)  length (2)  value, padded to 4; opt_endofopt (0) ends them
#include "output/pcapng_writer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "input/pcap.hpp"
#include "output/pcap_writer.hpp"
#include "output/record_text.hpp"
#include "util/io_block.hpp"
#include "util/text.hpp"

namespace rtuscope {

namespace {

using namespace std::string_view_literals;

constexpr std::uint32_t kSectionHeader = 0x0A0D0D0A;
constexpr std::uint32_t kInterfaceDescription = 1;
constexpr std::uint32_t kEnhancedPacket = 6;
constexpr std::uint32_t kByteOrderMagic = 0x1A2B3C4D;
constexpr std::uint16_t kOptEndOfOpt = 0;
constexpr std::uint16_t kOptComment = 1;
constexpr std::uint16_t kShbUserAppl = 4;
constexpr std::uint16_t kIfName = 2;
constexpr std::uint16_t kIfDescription = 3;
constexpr std::uint16_t kIfTsResol = 9;
constexpr std::uint16_t kEpbFlags = 2;
// epb_flags bits 0-1: the direction.
constexpr std::uint32_t kInbound = 1;
constexpr std::uint32_t kOutbound = 2;
constexpr std::uint8_t kNanoseconds = 9;  // if_tsresol: 10^-9 s
// An option's value is at most 65,535 bytes; a comment longer than that (hundreds of
// values) is cut at a line's end.
constexpr std::size_t kMaxOptionBytes = 0xFFFC;

void put16(std::vector<std::uint8_t>& out, std::uint16_t v) {
    out.push_back(static_cast<std::uint8_t>(v));
    out.push_back(static_cast<std::uint8_t>(v >> 8));
}

void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    put16(out, static_cast<std::uint16_t>(v));
    put16(out, static_cast<std::uint16_t>(v >> 16));
}

void pad32(std::vector<std::uint8_t>& out) {
    out.resize((out.size() + 3) & ~std::size_t{3}, 0);
}

void put_option(std::vector<std::uint8_t>& out, std::uint16_t code, std::string_view value) {
    put16(out, code);
    put16(out, static_cast<std::uint16_t>(value.size()));
    out.insert(out.end(), value.begin(), value.end());
    pad32(out);
}

void put_end_of_options(std::vector<std::uint8_t>& out) {
    put16(out, kOptEndOfOpt);
    put16(out, 0);
}

// `text` no longer than an option holds, cut after a line.
std::string_view option_sized(std::string_view text) {
    if (text.size() <= kMaxOptionBytes) return text;
    const std::size_t eol = text.rfind('\n', kMaxOptionBytes);
    return text.substr(0, eol == std::string_view::npos ? kMaxOptionBytes : eol);
}

const char* kind_phrase(const Record& record) {
    // An invalid frame is said as what it was read as, when it was read as something.
    if (record.kind == Kind::invalid) {
        switch (record.frame.reading) {
            case Reading::request:
                return "invalid request";
            case Reading::response:
                return "invalid response";
            case Reading::exception:
                return "invalid exception";
            case Reading::unknown:
                break;
        }
    }
    return to_string(record.kind).data();
}

}  // namespace

void append_frame_comment(std::string& out, const Record& record) {
    out += kOwnCommentPrefix;
    append_uint(out, record.number);
    out += ' ';
    out += kind_phrase(record);
    if (record.answer_number != 0) {
        out += ": answered by #"sv;
        append_uint(out, record.answer_number);
    }
    append_pairing(out, record, ": "sv);
    for (const Note& note : record.notes) {
        out += "\n! "sv;
        out += note.id;
        out += ": "sv;
        out += note.text;
    }
    const std::span<const DecodedValue> values = record.values;
    for (std::size_t i = 0; i < values.size();) {
        out += '\n';
        if (values[i].name.empty()) {
            i = append_unlisted_run(out, values, i);
            continue;
        }
        append_value(out, values[i], 0);
        out += " (raw "sv;
        out += values[i].raw;
        out += ')';
        if (!values[i].notes.empty()) {
            out += "  ! "sv;
            append_note_texts(out, values[i].notes);
        }
        ++i;
    }
}

PcapngSink::PcapngSink(std::FILE* file, std::string path)
    : file_(file), path_(std::move(path)), write_buffer_(give_stdio_buffer(file)) {}

PcapngSink::~PcapngSink() {
    if (file_ != nullptr) std::fclose(file_);
}

void PcapngSink::fail(const char* what, int err) {
    if (!error_) {
        error_ = Error{fmt::format("cannot {} the pcapng: {}", what, std::strerror(err)), path_};
    }
}

void PcapngSink::write(const void* data, std::size_t size) {
    if (error_ || file_ == nullptr) return;
    if (std::fwrite(data, 1, size, file_) != size) fail("write", errno);
}

void PcapngSink::write_block(std::uint32_t type, const std::vector<std::uint8_t>& body) {
    const auto length = static_cast<std::uint32_t>(body.size() + 12);
    block_.clear();
    put32(block_, type);
    put32(block_, length);
    block_.insert(block_.end(), body.begin(), body.end());
    put32(block_, length);
    write(block_.data(), block_.size());
}

void PcapngSink::begin(const SessionInfo& session) {
    session_ = session;
}

std::uint32_t PcapngSink::interface_for(const std::string& channel) {
    if (auto it = interfaces_.find(channel); it != interfaces_.end()) return it->second;
    const auto id = static_cast<std::uint32_t>(interfaces_.size());
    interfaces_.emplace(channel, id);
    body_.clear();
    put16(body_, static_cast<std::uint16_t>(kLinktypeUpperPdu));
    put16(body_, 0);  // reserved
    put32(body_, 0);  // snap length: none
    std::string name = session_.source.name.empty() ? "rtuscope" : session_.source.name;
    if (!channel.empty()) name += "@" + channel;
    put_option(body_, kIfName, option_sized(name));
    // The line as heard, unless 9600 8N1 was only assumed.
    if (session_.baud_origin != BaudOrigin::assumed) {
        put_option(body_, kIfDescription,
                   fmt::format("{} {}", session_.line.baud, session_.line.format()));
    }
    put16(body_, kIfTsResol);
    put16(body_, 1);
    body_.push_back(kNanoseconds);
    pad32(body_);
    put_end_of_options(body_);
    write_block(kInterfaceDescription, body_);
    return id;
}

void PcapngSink::record(const Record& record) {
    if (!is_written(record)) return;
    const std::uint32_t interface = interface_for(record.frame.channel);
    payload_.clear();
    append_pcap_packet(payload_, record);
    const auto t = static_cast<std::uint64_t>(std::max<Nanos>(0, packet_time(record)));
    body_.clear();
    put32(body_, interface);
    put32(body_, static_cast<std::uint32_t>(t >> 32U));
    put32(body_, static_cast<std::uint32_t>(t));
    put32(body_, static_cast<std::uint32_t>(payload_.size()));
    put32(body_, static_cast<std::uint32_t>(payload_.size()));
    body_.insert(body_.end(), payload_.begin(), payload_.end());
    pad32(body_);
    switch (direction_of(record)) {
        case FrameDirection::to_slave:
            put16(body_, kEpbFlags);
            put16(body_, 4);
            put32(body_, kOutbound);
            break;
        case FrameDirection::from_slave:
            put16(body_, kEpbFlags);
            put16(body_, 4);
            put32(body_, kInbound);
            break;
        case FrameDirection::unclear:
            break;
    }
    comment_.clear();
    append_frame_comment(comment_, record);
    put_option(body_, kOptComment, option_sized(comment_));
    // Comments read with the frame (someone's in Wireshark) go on with it.
    for (const std::string& comment : record.frame.comments) {
        put_option(body_, kOptComment, option_sized(comment));
    }
    put_end_of_options(body_);
    write_block(kEnhancedPacket, body_);
    if (!error_) ++packets_;
}

void PcapngSink::flush() {
    if (error_ || file_ == nullptr) return;
    if (std::fflush(file_) != 0) fail("write", errno);
}

void PcapngSink::end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) {
    if (file_ == nullptr) return;
    flush();
    // fclose reports what the kernel refused last (a full disk shows up here).
    if (std::fclose(file_) != 0) fail("close", errno);
    file_ = nullptr;
}

Status PcapngSink::status() const {
    if (error_) return *error_;
    return ok_status();
}

Result<std::unique_ptr<PcapngSink>> make_pcapng_sink(const std::string& path,
                                                    std::string_view application) {
    std::FILE* file = std::fopen(path.c_str(), "wbe");
    if (file == nullptr) {
        return Error{fmt::format("cannot create the pcapng: {}", std::strerror(errno)), path};
    }
    std::unique_ptr<PcapngSink> sink(new PcapngSink(file, path));
    std::vector<std::uint8_t> body;
    put32(body, kByteOrderMagic);
    put16(body, 1);  // version 1.0
    put16(body, 0);
    put32(body, 0xFFFFFFFF);  // section length: not given
    put32(body, 0xFFFFFFFF);
    put_option(body, kShbUserAppl, option_sized(application));
    put_end_of_options(body);
    sink->write_block(kSectionHeader, body);
    sink->flush();
    if (Status s = sink->status(); !s) return s.error();
    return sink;
}

}  // namespace rtuscope
