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

}  // namespace rtuscope
