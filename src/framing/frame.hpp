// The framer's output record: a frame (CRC right, swapped or wrong) or a run of noise.
// Every input byte ends up in exactly one Frame.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "framing/crc.hpp"
#include "framing/functions.hpp"
#include "framing/note.hpp"
#include "framing/transport.hpp"
#include "util/time.hpp"

namespace rtuscope {

enum class RecordClass : std::uint8_t {
    frame,    // address, function code, data and a CRC (ok or swapped)
    invalid,  // looks like a frame but the CRC is wrong or it was cut short
    noise,    // bytes that form no frame
};

// What told the framer where the frame ends.
enum class Delimiter : std::uint8_t {
    gap,           // silence of at least t3.5 after it
    length_crc,    // the length the function code implies, confirmed by the CRC
    crc_search,    // no field gives the length: found by the CRC over possible lengths
    end_of_input,  // input ended
    line,          // hex logs: one line, one frame
};

// Which reading of the bytes the framer chose (Modbus request or answer layout).
enum class Reading : std::uint8_t { request, response, exception, unknown };

// Function code and data of a frame's bytes, without the address or unit id and the CRC.
std::span<const std::uint8_t> pdu_of(std::span<const std::uint8_t> bytes, Transport transport);

struct Frame {
    Nanos start = kNoTime;  // first byte's start (estimated from the chunk timing)
    Nanos end = kNoTime;    // last byte's end
    // Silence before the first byte when the input shows it (the frame began a chunk);
    // kNoTime when it arrived inside a chunk and its start is only an estimate.
    Nanos silence_before = kNoTime;
    std::vector<std::uint8_t> bytes;
    RecordClass cls = RecordClass::noise;
    Reading reading = Reading::unknown;
    Delimiter delimiter = Delimiter::end_of_input;
    CrcCheck crc;
    std::string channel;
    int source_line = 0;  // input line of the first byte, 0 if none
    Notes notes;
    Transport transport = Transport::rtu;
    Mbap mbap{};  // Modbus/TCP only
    // What a pcapng file says of the frame in comments of its own (Chunk::comments).
    std::vector<std::string> comments;

    [[nodiscard]] bool is_frame() const { return cls != RecordClass::noise; }
    [[nodiscard]] std::uint8_t slave() const { return bytes.empty() ? 0 : bytes[0]; }
    [[nodiscard]] std::uint8_t function() const { return bytes.size() < 2 ? 0 : bytes[1]; }
    // function code and data, without the address (unit id) and the CRC
    [[nodiscard]] std::span<const std::uint8_t> pdu() const { return pdu_of(bytes, transport); }
    // Becomes `other`, giving it this frame's byte and note buffers in exchange: a frame
    // handed on once per record costs no copy and no allocation. Sets every field (a new
    // field must be added there too).
    void take(Frame& other) {
        bytes.swap(other.bytes);
        notes.swap(other.notes);
        // Nearly always none: the frame handed on keeps none either.
        comments.swap(other.comments);
        other.comments.clear();
        // Nearly always the same channel (none): compared rather than assigned or swapped.
        if (channel != other.channel) channel = other.channel;
        start = other.start;
        end = other.end;
        silence_before = other.silence_before;
        cls = other.cls;
        reading = other.reading;
        delimiter = other.delimiter;
        crc = other.crc;
        source_line = other.source_line;
        transport = other.transport;
        mbap = other.mbap;
    }
};

const char* to_string(RecordClass cls);
const char* to_string(Delimiter delimiter);

// Whether `bytes` are exactly one frame by length and CRC: the CRC checks (or checks
// swapped) and the length is one its function code gives, as a request or an answer; for
// a code whose length no field gives (FC08/00, unknown codes), the CRC checking at this
// length is enough.
bool is_whole_frame(std::span<const std::uint8_t> bytes, const ProtocolRules& rules);

}  // namespace rtuscope
