// --guess: what the registers no profile types could be. An unknown device's answer is
// raw words; these are the readings a person would try by hand (the word as unsigned and
// signed, two adjacent words as a 32-bit integer or float in either word order), with
// the floats no device would send (NaN, infinities, denormals, absurd magnitudes) left out.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "decode/decoder.hpp"
#include "profiles/profile.hpp"
#include "util/reused_list.hpp"

namespace rtuscope {

namespace note_id {
inline constexpr const char* value_guess = "value.guess";  // a reading --guess tries
}  // namespace note_id
// The text of that note, where outputs give a value's note texts.
inline constexpr const char* kGuessNoteText = "a guess: no profile covers the register";

// How a guess reads its register or registers.
enum class GuessType : std::uint8_t { u16, i16, u32_abcd, u32_cdab, f32_abcd, f32_cdab };

// "u16", "i16", "u32/abcd", "u32/cdab", "f32/abcd", "f32/cdab".
const char* reading_name(GuessType reading);
// Registers the reading takes: 1 or 2.
std::uint16_t reading_registers(GuessType reading);

struct GuessedReading {
    std::uint16_t address = 0;  // its first register
    GuessType reading = GuessType::u16;
    std::string value;  // "16752", "-200", "15.0"
    std::string raw;    // the word(s) in wire order: "0x4170 0x0000"

    void clear();  // empties it, keeping the buffers
};

// The reading of a register's word `first` (and, for 32-bit readings, of the next
// register's `second`), as text; nullopt when it is not worth showing: an i16 equal to
// its u16 (top bit clear), an implausible float.
std::optional<std::string> read_words(GuessType reading, std::uint16_t first,
                                      std::uint16_t second = 0);

// Whether a float is one a device plausibly sends: 0, or finite with a magnitude from
// 1e-6 to 1e9 (which leaves out denormals and the huge or tiny numbers that any two
// words of an integer make when read as a float).
bool plausible_float(float value);

// The readings of the block's registers that `profile` (none: every register) does not
// cover, appended to `out` in address order; of each register its u16 (and i16 when
// it differs), then of it and the next register in the block, when neither is covered,
// the 32-bit readings. Only register tables (holding, input) are guessed: bits need no
// guess, and a device's own function codes have their profile.
void guess_readings(const Profile* profile, const DataBlock& block,
                    ReusedList<GuessedReading>& out);

}  // namespace rtuscope
