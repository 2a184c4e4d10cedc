// What the framer and the pairing need to know about the Modbus application protocol:
// how long a frame is (from its function code and length fields) and which answers echo
// their request. The standard rules live here; a device profile overrides them per slave
// address (non-standard function codes, other broadcast addresses, echoes).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace rtuscope {

enum class Role : std::uint8_t { request, response };

// The ADU (address + PDU + CRC) limit of Modbus over serial line.
inline constexpr std::size_t kMaxAdu = 256;
inline constexpr std::size_t kMinAdu = 4;  // address, function, CRC

struct FrameLength {
    enum class Kind : std::uint8_t {
        fixed,      // `bytes` is the whole ADU length, CRC included
        need_more,  // at least `bytes` bytes must be seen to know the length
        search,     // no field gives the length (FC08/00, unknown codes): try the CRC
        none,       // the function code has no such reading (e.g. an exception request)
    };
    Kind kind = Kind::none;
    std::size_t bytes = 0;

    static FrameLength fixed_at(std::size_t n) { return {Kind::fixed, n}; }
    static FrameLength need(std::size_t n) { return {Kind::need_more, n}; }
    static FrameLength search_crc() { return {Kind::search, 0}; }
    static FrameLength no_reading() { return {Kind::none, 0}; }

    // A length the bytes in hand hold whole: a frame's length, at least kMinAdu.
    [[nodiscard]] bool fixed_within(std::size_t avail) const {
        return kind == Kind::fixed && bytes >= kMinAdu && bytes <= avail;
    }
};

// The lengths of the two ways the same bytes can be read. Every caller wants both, and
// most codes give both from one look at the function code.
struct FrameLengths {
    FrameLength request;
    FrameLength response;

    [[nodiscard]] const FrameLength& of(Role role) const {
        return role == Role::request ? request : response;
    }
};

class ProtocolRules {
  public:
    virtual ~ProtocolRules() = default;

    // Lengths of an ADU that starts with `head` (address first), read as a request and
    // as an answer (normal or exception).
    [[nodiscard]] virtual FrameLengths frame_lengths(std::span<const std::uint8_t> head) const;
    // Whether a normal answer to this function code repeats the request (05, 06, 08, ...),
    // so order and timing, not shape, tell request from answer.
    [[nodiscard]] virtual bool answer_is_echo(std::uint8_t slave, std::uint8_t function) const;
    // Whether a request to this address expects no answer (standard: address 0).
    [[nodiscard]] virtual bool is_broadcast(std::uint8_t slave) const;
    // Whether this function code is ever answered (a device may define one that is not).
    [[nodiscard]] virtual bool expects_answer(std::uint8_t slave, std::uint8_t function) const;
    // Whether the device answers errors with exception frames (some stay silent).
    [[nodiscard]] virtual bool answers_errors(std::uint8_t slave) const;
};

// The standard rules, for users that have no profile.
const ProtocolRules& standard_rules();

}  // namespace rtuscope
