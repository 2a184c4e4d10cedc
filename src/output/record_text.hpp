// The phrases the text output and the pcapng comments say of a record alike: its pairing,
// its notes, its values. One wording, wherever it is read.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "framing/note.hpp"
#include "pairing/transactions.hpp"
#include "profiles/values.hpp"

namespace rtuscope {

// An answer's pairing: `before`, then "4.53 ms after #12" (its turnaround) or "answers #12"
// (none measured); nothing for a record that answers no request.
void append_pairing(std::string& out, const Record& record, std::string_view before);

// "first; second": the notes' texts in the order they were noticed.
void append_note_texts(std::string& out, std::span<const Note> notes);

// "voltage = 220.5 V", the name padded to `name_width`.
void append_value(std::string& out, const DecodedValue& value, std::size_t name_width);

// The registers from values[i] on that the profile does not list, as one run ("0010..0013
// not in the profile: 4 registers, all 0"): devices often fill unused ranges with zeros.
// Returns the end of the run.
std::size_t append_unlisted_run(std::string& out, std::span<const DecodedValue> values,
                                std::size_t i);

// The guessed readings (--guess) from guesses[i] on of one register, and of it with the
// next one: "guess 0x0002 (0xFF38): u16 65336, i16 -200 | with 0x0003: u32/abcd ...,
// f32/cdab 15.0". Registers whose every reading is 0, two or more in a row, as one line:
// "guess 0x0010..0x0013: 4 registers, all 0". Returns the index after what it showed.
std::size_t append_guess_line(std::string& out, std::span<const GuessedReading> guesses,
                              std::size_t i);

}  // namespace rtuscope
