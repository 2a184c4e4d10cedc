// Stage 3 of `profiles infer`: the interpretations of each register scored over the whole
// capture, and the one chosen, with its evidence, the other types its values fit, and a
// confidence.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "infer/poll_map.hpp"
#include "profiles/profile.hpp"

namespace rtuscope::infer {

enum class Confidence : std::uint8_t { low, medium, high };
const char* confidence_name(Confidence confidence);

struct RegisterGuess {
    Table table = Table::holding;
    std::uint16_t address = 0;
    ValueType type = ValueType::u16;
    WordOrder word_order = WordOrder::abcd;  // types of two registers
    std::uint16_t length = 1;
    Access access = Access::read;
    Confidence confidence = Confidence::low;
    // Other types (and orders) the values fit as well: the choice between them is not the
    // values' to make.
    struct Alternative {
        ValueType type = ValueType::u16;
        WordOrder word_order = WordOrder::abcd;
    };
    std::vector<Alternative> alternatives;
    bool constant = false;
    bool counter = false;                // only ever increases: a total
    std::vector<std::uint16_t> labels;   // enum values, or the bits that toggle
    std::vector<std::string> evidence;   // what was seen, for the comment

    [[nodiscard]] bool ambiguous() const { return !alternatives.empty(); }
    // Whether `type` (and, for several registers, `order`) is the chosen reading or one of
    // the alternatives.
    [[nodiscard]] bool accepts(ValueType type, WordOrder order) const;
};

struct DeviceGuess {
    std::uint8_t slave = 0;
    std::vector<std::string> poll_map;     // one line per read block and written register
    std::vector<RegisterGuess> registers;  // by table, then address
    std::uint64_t answered_reads = 0;
};

DeviceGuess infer_device(const SlaveTraffic& traffic);

// "u16", "f32 cdab": a type as a comment or a message names it.
std::string reading_name(ValueType type, WordOrder order);

}  // namespace rtuscope::infer
