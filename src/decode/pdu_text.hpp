// The pieces of a PDU's one-line summary ("2 registers: 0x1818 0x0000", "0x0013 x10"),
// each appended to the record's summary string, which keeps its buffer record after record.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "util/text.hpp"

namespace rtuscope {

// A summary stays one readable line: longer lists end in "... (+N more)". The values
// themselves all go into the data blocks.
inline constexpr std::size_t kListedWords = 8;
inline constexpr std::size_t kListedBits = 64;

// "2 registers"
void append_counted(std::string& out, std::size_t n, std::string_view one, std::string_view many);
// "0x1818 0x0000", at most kListedWords of them.
void append_word_list(std::string& out, std::span<const std::uint16_t> values);
// ": 0x1818 0x0000" or ": 1011" (bits); nothing for no values.
void append_values(std::string& out, std::span<const std::uint16_t> values, bool as_bits);
// "2 registers: 0x1818 0x0000", "0 registers".
void append_listed(std::string& out, std::span<const std::uint16_t> values, std::string_view one,
                   std::string_view many, bool as_bits);
// "0x0013 x10" from whichever of the two fields is present.
void append_range(std::string& out, std::optional<std::uint16_t> start,
                  std::optional<std::uint16_t> qty);
// A device string in quotes: printable ASCII as it is, the rest escaped ("\x00").
void append_quoted(std::string& out, std::span<const std::uint8_t> bytes);
// `separator` before the next part of a list, unless `out` is still empty.
void append_separator(std::string& out, std::string_view separator);

// Registers, two bytes each, big-endian (section 4.2).
void words_of(std::span<const std::uint8_t> bytes, std::vector<std::uint16_t>& words);
// Bits in address order: the LSB of the first byte is the first address (6.1).
void bits_of(std::span<const std::uint8_t> bytes, std::size_t count,
             std::vector<std::uint16_t>& bits);

}  // namespace rtuscope
