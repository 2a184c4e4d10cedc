// The Modbus function codes: one table, one entry per code, holding what every stage needs
// to know of it, as Wireshark keeps function_code_vals[] and tcpdump its tok2str tables.
//   framing   how long the request and the answer are (from the code and length fields)
//   pairing   whether the answer repeats the request, or never comes
//   decode    the name, the data it reads or writes, the quantity limit, the decoders
// The standard entries follow the MODBUS Application Protocol Specification V1.1b3,
// section 6 (ADU = address + PDU + CRC, so every length below is the PDU length + 3). A
// device profile's own function codes (profiles/profile.hpp) are entries of the same
// shape; ProtocolRules picks the one that applies to a slave.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace rtuscope {

enum class Role : std::uint8_t { request, response };

// The ADU (address + PDU + CRC) limit of Modbus over serial line.
inline constexpr std::size_t kMaxAdu = 256;
inline constexpr std::size_t kMinAdu = 4;  // address, function, CRC

// The four tables of the Modbus data model (section 4.3); `none` for functions that read
// or write none of them.
enum class DataTable : std::uint8_t {
    none,
    coils,
    discrete_inputs,
    holding_registers,
    input_registers
};

// What a function does with its table.
enum class DataAccess : std::uint8_t { none, read, write, read_write };

// The length of one reading of the bytes at a position, as far as they tell it.
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

// How a function code's request or answer tells its length.
struct LengthRule {
    enum class Kind : std::uint8_t {
        fixed,     // always `n` bytes
        counted,   // a byte count at offset `n`, then that many bytes and the CRC
        search,    // no field gives it: the CRC over the possible lengths
        none,      // never sent (a device's function without an answer)
        computed,  // `compute` reads the fields (sub-functions, lists of objects)
        standard,  // a device's own request whose length the profile does not give: as the
                   // standard entry of its code says
    };
    Kind kind = Kind::search;
    std::uint16_t n = 0;
    FrameLength (*compute)(std::span<const std::uint8_t> head) = nullptr;

    static constexpr LengthRule fixed(std::uint16_t bytes) { return {Kind::fixed, bytes, nullptr}; }
    static constexpr LengthRule counted(std::uint16_t at) { return {Kind::counted, at, nullptr}; }
    static constexpr LengthRule search() { return {Kind::search, 0, nullptr}; }
    static constexpr LengthRule none() { return {Kind::none, 0, nullptr}; }
    static constexpr LengthRule standard() { return {Kind::standard, 0, nullptr}; }
    static constexpr LengthRule computed(FrameLength (*f)(std::span<const std::uint8_t>)) {
        return {Kind::computed, 0, f};
    }

    // The length of the ADU that starts with `head` (address and function code at least).
    // `standard` is resolved by the caller.
    [[nodiscard]] FrameLength of(std::span<const std::uint8_t> head) const;
};

// What follows a request.
enum class Answer : std::uint8_t {
    reply,  // an answer of the function's own layout
    echo,   // the request repeated (05, 06, 08, 15, 16): order and timing, not shape, tell
            // request from answer
    none,   // nothing: a device's function that is never answered
};

// Decodes one PDU of this function (decode/pdu_decoding.hpp).
struct PduDecoding;
using PduDecoder = void (*)(PduDecoding&);

enum class RequestWord : std::uint8_t { none, quantity, on_off };

struct FunctionSpec {
    std::uint8_t code = 0;
    std::string name;  // "Read Holding Registers"; "Function 0x41" for codes without one
    LengthRule request_length;
    LengthRule response_length;  // a normal answer's (an echo's is the request's)
    Answer answer = Answer::reply;
    DataTable table = DataTable::none;  // what its data addresses, if anything
    DataAccess access = DataAccess::none;
    // The most items one request may read or write (section 6), 0 where it carries no
    // quantity.
    std::uint16_t max_quantity = 0;
    // The request's word after the address (bytes 4-5), which the framer checks in a frame
    // whose CRC fails: a quantity up to max_quantity, or a coil's FF00 (on) or 0000 (off),
    // all else illegal (6.5).
    RequestWord request_word = RequestWord::none;
    bool answer_repeats_word = false;  // the answer repeats the address and that word
    PduDecoder decode_request = nullptr;
    PduDecoder decode_response = nullptr;  // normal answers; exceptions decode alike for all
    // A device's own function: the profile table its data refers to ("eeprom"), in place
    // of `table`.
    std::string device_table;

    // Whether `word` is a request word this function allows (request_word not none).
    [[nodiscard]] bool allows_request_word(std::uint16_t word) const {
        return request_word == RequestWord::on_off ? word == 0xFF00 || word == 0x0000
                                                   : word >= 1 && word <= max_quantity;
    }
};

// The standard entry of a function code (the exception bit ignored): its section 6 entry,
// or for codes without one an entry that searches the length by CRC and shows the data as
// bytes.
const FunctionSpec& standard_function(std::uint8_t code);

// What the framer and the pairing ask about the protocol. The standard rules answer
// from the table; a bus map with device profiles (profiles/bus.hpp) answers per slave.
class ProtocolRules {
  public:
    virtual ~ProtocolRules() = default;

    // The entry that applies to this function code (its exception bit ignored) on this
    // slave address.
    [[nodiscard]] virtual const FunctionSpec& function(std::uint8_t slave, std::uint8_t code) const;
    // Whether a request to this address expects no answer (standard: address 0).
    [[nodiscard]] virtual bool is_broadcast(std::uint8_t slave) const;
    // Whether the device answers errors with exception frames (some stay silent).
    [[nodiscard]] virtual bool answers_errors(std::uint8_t slave) const;

    // Lengths of an ADU that starts with `head` (address first), read as a request and
    // as an answer (normal or exception).
    [[nodiscard]] FrameLengths frame_lengths(std::span<const std::uint8_t> head) const;
    // Whether a normal answer to this function code repeats the request.
    [[nodiscard]] bool answer_is_echo(std::uint8_t slave, std::uint8_t code) const {
        return function(slave, code).answer == Answer::echo;
    }
    // Whether this function code is ever answered.
    [[nodiscard]] bool expects_answer(std::uint8_t slave, std::uint8_t code) const {
        return function(slave, code).answer != Answer::none;
    }
};

// The standard rules, for users that have no profile.
const ProtocolRules& standard_rules();

}  // namespace rtuscope
