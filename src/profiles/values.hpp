// Register values in the device's own words: a DataBlock (addresses and raw words from
// a decoded frame) explained with a Profile.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "decode/decoder.hpp"
#include "framing/note.hpp"
#include "profiles/profile.hpp"
#include "util/reused_list.hpp"

namespace rtuscope {

namespace note_id {
inline constexpr const char* value_out_of_range = "value.out_of_range";
inline constexpr const char* value_partial = "value.partial";        // part of a multi-register value
inline constexpr const char* value_unlisted = "value.unlisted";      // not in the profile
inline constexpr const char* value_read_only = "value.read_only";    // written but read-only
inline constexpr const char* value_write_only = "value.write_only";  // read but write-only
}  // namespace note_id

struct DecodedValue {
    std::uint16_t address = 0;  // first register of the value
    std::string name;           // the register's name; empty when the profile has none
    std::string value;          // "220.5", "-5.0", an enum label, bit names, a string
    std::string unit;
    std::string raw;  // the register word(s) in hex: "0x089D", "0x0000 0x3039"
    Notes notes;      // value.* diagnostics for this value

    void clear();  // empties it, keeping the buffers for the next record's values
};

// Every value the block carries, in address order, appended to `out` (a record's values,
// whose items are reused record after record). Registers the profile does not list come
// out one per register with an empty name and a value.unlisted note; a 32-bit register
// only half in the block comes out with its half and a value.partial note.
void decode_values(const Profile& profile, const DataBlock& block, ReusedList<DecodedValue>& out);

// The profile table a block of a standard function code belongs to.
const char* table_name(DataTable table);

}  // namespace rtuscope
