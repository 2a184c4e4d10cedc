#include "profiles/guess.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <span>
#include <string_view>

#include "profiles/values.hpp"
#include "util/text.hpp"

namespace rtuscope {
namespace {

struct ReadingSpec {
    GuessType reading;
    const char* name;
    std::uint16_t registers;
};

// In the order a register's readings are shown.
constexpr std::array<ReadingSpec, 6> kReadings{{
    {GuessType::u16, "u16", 1},
    {GuessType::i16, "i16", 1},
    {GuessType::u32_abcd, "u32/abcd", 2},
    {GuessType::u32_cdab, "u32/cdab", 2},
    {GuessType::f32_abcd, "f32/abcd", 2},
    {GuessType::f32_cdab, "f32/cdab", 2},
}};

const ReadingSpec& spec_of(GuessType reading) {
    return kReadings[static_cast<std::size_t>(reading)];
}

// Shortest digits that read back as the same float, with ".0" on a whole number so that
// a float never looks like an integer reading: 15.0, 0.1, 1e+09.
std::string float_text(float value) {
    std::string text = fmt::format("{}", value);
    if (text == "-0") text = "0";
    if (text.find_first_not_of("-0123456789") == std::string::npos) text += ".0";
    return text;
}

bool covered(std::span<const Register> registers, std::uint16_t address) {
    const Register* reg = Profile::covering(registers, address);
    return reg != nullptr && reg->address <= address &&
           std::size_t{address} - reg->address < reg->length;
}

void add_reading(GuessType reading, std::uint16_t address, std::span<const std::uint16_t> words,
                 ReusedList<GuessedReading>& out) {
    auto text = read_words(reading, words[0], words.size() > 1 ? words[1] : 0);
    if (!text) return;
    GuessedReading& g = out.add();
    g.address = address;
    g.reading = reading;
    g.value = std::move(*text);
    for (std::size_t i = 0; i < words.size(); ++i) {
        if (i > 0) g.raw += ' ';
        append_hex4(g.raw, words[i]);
    }
}

}  // namespace

const char* reading_name(GuessType reading) {
    return spec_of(reading).name;
}

std::uint16_t reading_registers(GuessType reading) {
    return spec_of(reading).registers;
}

bool plausible_float(float value) {
    if (value == 0) return true;
    const float magnitude = std::abs(value);
    return std::isfinite(value) && magnitude >= 1e-6F && magnitude <= 1e9F;
}

std::optional<std::string> read_words(GuessType reading, std::uint16_t first,
                                      std::uint16_t second) {
    const std::uint32_t abcd = (std::uint32_t{first} << 16U) | second;
    const std::uint32_t cdab = (std::uint32_t{second} << 16U) | first;
    switch (reading) {
        case GuessType::u16:
            return std::to_string(first);
        case GuessType::i16:
            if ((first & 0x8000U) == 0) return std::nullopt;
            return std::to_string(static_cast<std::int16_t>(first));
        case GuessType::u32_abcd:
            return std::to_string(abcd);
        case GuessType::u32_cdab:
            return std::to_string(cdab);
        case GuessType::f32_abcd:
        case GuessType::f32_cdab: {
            const float value =
                std::bit_cast<float>(reading == GuessType::f32_abcd ? abcd : cdab);
            if (!plausible_float(value)) return std::nullopt;
            return float_text(value);
        }
    }
    return std::nullopt;
}

void GuessedReading::clear() {
    address = 0;
    reading = GuessType::u16;
    value.clear();
    raw.clear();
}

void guess_readings(const Profile* profile, const DataBlock& block,
                    ReusedList<GuessedReading>& out) {
    const bool register_table = block.table == DataTable::holding_registers ||
                                block.table == DataTable::input_registers;
    if (!register_table || !block.custom_table.empty()) return;
    const std::span<const Register> registers =
        profile != nullptr ? profile->registers_in(table_name(block.table))
                           : std::span<const Register>();
    // Addresses do not wrap around, as in decode_values.
    const std::size_t count =
        std::min<std::size_t>(block.values.size(), std::size_t{0x10000} - block.start);
    const std::span<const std::uint16_t> words(block.values.data(), count);
    bool next_free = count > 0 && !covered(registers, block.start);
    for (std::size_t i = 0; i < count; ++i) {
        const auto address = static_cast<std::uint16_t>(block.start + i);
        const bool free = next_free;
        next_free = i + 1 < count && !covered(registers, static_cast<std::uint16_t>(address + 1));
        if (!free) continue;
        for (const ReadingSpec& spec : kReadings) {
            if (spec.registers == 2 && !next_free) continue;
            add_reading(spec.reading, address, words.subspan(i, spec.registers), out);
        }
    }
}

}  // namespace rtuscope
