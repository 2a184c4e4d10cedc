// Device profiles: what one device model's registers mean (names, types, scales, units)
// and how it bends the Modbus standard (its own function codes, broadcast address,
// silence instead of exception answers). Profiles are data files (TOML, see
// docs/profiles.md); this is their in-memory form.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "framing/functions.hpp"
#include "framing/line_settings.hpp"
#include "util/result.hpp"

namespace rtuscope {

enum class ValueType : std::uint8_t {
    u16,
    i16,
    u32,
    i32,
    f32,
    u64,
    i64,
    f64,
    bits,
    enumeration,
    string
};

// How the bytes of a value of several registers lie on the wire, in the letters Modbus
// tools use for a 32-bit value whose most significant byte is A: abcd is big-endian,
// cdab has the registers swapped, badc the bytes within each register, dcba both. A
// 64-bit value extends the pattern: cdab and dcba put its least significant register
// first (docs/profiles.md draws it).
enum class WordOrder : std::uint8_t { abcd, cdab, badc, dcba };

// The type a profile names ("u32", "enum"), or nullopt.
std::optional<ValueType> value_type_named(std::string_view name);
// Whether values of the type are numbers (scaled, compared, published as numbers), not
// labels, bit names or text.
bool is_numeric(ValueType type);
// What a profile calls the type: value_type_named(value_type_name(t)) == t.
const char* value_type_name(ValueType type);
// Every type name, for messages: "u16, i16, ..., string".
const char* value_type_names();
// Registers a value of the type takes: 1, 2 or 4; 0 for a string, whose length says.
std::uint16_t registers_of(ValueType type);
// Whether the type takes several registers, and so a word order (u32 ... f64).
bool is_multi_register(ValueType type);

// The order a profile names ("cdab"; "high_first" is abcd, "low_first" cdab), or nullopt.
std::optional<WordOrder> word_order_named(std::string_view name);
// The order's name: "high_first" and "low_first" for abcd and cdab, the letters for
// the others.
const char* word_order_name(WordOrder order);
// Every order name, for messages.
const char* word_order_names();
// What an order does to the words read: the register order reversed (least significant
// first), and the two bytes of each register swapped.
bool reverses_registers(WordOrder order);
bool swaps_bytes(WordOrder order);

enum class Access : std::uint8_t { read, write, read_write };
// As a profile file writes it: "R", "W", "RW".
const char* access_text(Access access);

// Where in the file a definition stands, for messages (1-based; 0 = unknown).
struct SourcePos {
    int line = 0;
    int column = 0;
};

// The scale `decimals = N` gives a register: 10^-N for N in 0-9 (what a profile may
// give), computed once; 0, which no scale is, for any other N.
double scale_for_decimals(int decimals);

// A number written in decimal or 0x hex, up to `max` ("247", "0x4082"), or nullopt.
std::optional<unsigned> parse_number_up_to(std::string_view text, unsigned max);

// Whether a profile table holds single bits ("coil", "discrete") rather than registers.
bool is_bit_table(std::string_view table);

struct Register {
    std::string table = "holding";  // "holding", "input", "coil", "discrete" or a custom
                                    // table of a non-standard function code
    std::uint16_t address = 0;
    std::string name;  // unique in the profile (after formula expansion)
    ValueType type = ValueType::u16;
    WordOrder word_order = WordOrder::abcd;  // types of several registers
    std::uint16_t length = 1;  // registers: 1, 2 or 4 (registers_of), n for strings
    double scale = 1.0;        // value = raw * scale (decimals d gives scale 10^-d)
    int decimals = -1;         // digits to print; -1: as many as the scale implies
    std::string unit;
    Access access = Access::read;
    std::optional<double> min;  // valid range, in scaled units
    std::optional<double> max;
    std::string description;
    std::map<std::uint32_t, std::string> labels;  // enum values, or bit number -> bit name
    std::map<std::uint32_t, std::string> writes;  // raw values with a special meaning when
                                                  // written (0xAABB = "clear energy")
    // Home Assistant's classes for the register's sensor, where the profile overrides the
    // ones its unit implies: nullopt derives them, "" gives none.
    std::optional<std::string> ha_device_class;
    std::optional<std::string> ha_state_class;
    SourcePos pos;
};

struct Profile {
    std::string name;                  // "zb-uvi485": what --device and the bus file use
    std::string title;                 // "ZB-UVI485 UV-intensity transmitter (Chongqing Zibo)"
    std::string source;                // where the facts come from (manual, version)
    std::string file;                  // file it was read from ("<bundled>/zb-uvi485.toml")
    std::optional<LineSettings> line;  // the device's default line settings
    std::uint8_t first_address = 1;    // valid slave addresses
    std::uint8_t last_address = 247;
    std::optional<std::uint8_t> broadcast;  // non-standard broadcast address (0xFF)
    bool exception_answers = true;          // false: errors are answered with silence
    std::uint16_t max_registers = 125;      // per read request
    // The device's own function codes ([[function]]): entries of the function table's
    // shape (framing/functions.hpp), whose length, answer and decoders replace the
    // standard entry's for this device's slaves.
    std::vector<FunctionSpec> functions;
    std::vector<Register> registers;  // sorted by table, then address

    // The device's own entry for `code`, or nullptr where the standard's applies.
    [[nodiscard]] const FunctionSpec* function(std::uint8_t code) const;
    // The register that starts at `address` in `table`, or nullptr.
    [[nodiscard]] const Register* register_at(const std::string& table,
                                              std::uint16_t address) const;
    // The register whose addresses include `address` (the second half of a 32-bit value
    // too), or nullptr.
    [[nodiscard]] const Register* register_covering(const std::string& table,
                                                    std::uint16_t address) const;
    // The registers of one table, in address order: a block is of one table, so it is
    // looked up once per block, not once per value.
    [[nodiscard]] std::span<const Register> registers_in(std::string_view table) const;
    // register_covering within what registers_in gave.
    [[nodiscard]] static const Register* covering(std::span<const Register> table,
                                                  std::uint16_t address);
};

// The entry a [[function]] of `code` starts from: the standard entry's lengths and
// answer, its length as the standard's (LengthRule::standard), and the data the device's
// own: no standard table or quantity, shown as bytes, of the table "holding" unless the
// profile names another.
FunctionSpec own_function(std::uint8_t code);

// One mistake in a profile file, with its position.
struct ProfileProblem {
    std::string file;
    int line = 0;
    int column = 0;
    std::string message;
    [[nodiscard]] std::string to_string() const;  // "FILE:LINE:COL: message"
};

// Reads and validates one profile. Every mistake is reported (not just the first):
// on any problem the result is an error whose message lists them one per line.
struct ProfileLoad {
    std::optional<Profile> profile;
    std::vector<ProfileProblem> problems;
};
ProfileLoad load_profile_text(const std::string& text, const std::string& file_name);
ProfileLoad load_profile_file(const std::string& path);

// The four seed devices, built into the binary.
const std::vector<Profile>& bundled_profiles();
// For tests: what is wrong with the bundled files (nothing, in a good build).
std::vector<ProfileProblem> bundled_profile_problems();
std::size_t bundled_profile_file_count();

}  // namespace rtuscope
