// Trigger expressions (--trigger EXPR, docs/formats.md "Trigger expressions"): what makes
// a record an event. An expression is terms joined by commas, all of which must hold:
// kind=, slave=, function= (the lists of --kind, --slave, --function), flag= (note ids),
// crc= (ok, bad, swapped), and comparisons of a register's value (voltage>250). The
// expression is parsed once; matching a record then parses nothing and allocates nothing,
// as it runs on every record of a live line.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "framing/crc.hpp"
#include "output/filter.hpp"
#include "pipeline.hpp"
#include "profiles/bus.hpp"
#include "profiles/profile.hpp"
#include "util/result.hpp"

namespace rtuscope {

// What a trigger's terms may name: the profiles of the devices on the bus, whose register
// names a comparison takes. A name none of them has is an error, not a trigger that never
// fires.
struct TriggerContext {
    std::vector<const Profile*> profiles;
};

// The profiles the bus assigns to some address (none without a bus).
TriggerContext trigger_context(const Bus* bus);

// flag=LIST: a record carrying any of these notes, its own or one of its values'.
struct FlagTerm {
    std::vector<std::string_view> ids;  // from known_note_ids()
};

// crc=LIST: a frame whose CRC is one of these (the CSV crc column's words).
struct CrcTerm {
    std::vector<CrcStatus> statuses;
};

// NAME=A,B or NAME<N, NAME>N, NAME<=N, NAME>=N: a record carrying a value of register NAME
// (any device's) that compares so. Numbers compare as numbers, as the value is shown
// (voltage=220 matches "220.0"); anything else (enum labels, strings) by equal text.
struct ValueTerm {
    enum class Op : std::uint8_t { equal, less, greater, less_equal, greater_equal };
    struct Operand {
        std::string text;
        std::optional<double> number;  // the text as a number, when it is one
    };
    std::string name;
    Op op = Op::equal;
    std::vector<Operand> operands;  // `equal`: any of them; the others: exactly one
};

// kind=, slave= and function= are each a RecordFilter with that one list: the one meaning
// those lists have, whether they filter the output or trigger.
using TriggerTerm = std::variant<RecordFilter, FlagTerm, CrcTerm, ValueTerm>;

struct Trigger {
    std::string expression;         // as given, for messages
    std::vector<TriggerTerm> terms;  // all must hold

    [[nodiscard]] bool matches(const Record& record) const;
};

// `expr` parsed, or an Error whose message starts "column N: " (1-based, into `expr`) and
// whose column is N: the caller prefixes the option ("--trigger: column 9: ...").
Result<Trigger> parse_trigger(std::string_view expr, const TriggerContext& context);

// The note ids a flag= term takes: those of docs/formats.md that records carry.
std::span<const std::string_view> known_note_ids();

// --trigger is repeatable and any one fires: the index of the first trigger that matches
// the record, if any.
std::optional<std::size_t> first_firing(std::span<const Trigger> triggers, const Record& record);

// Called for a record that fires a trigger, with the index of the first one it fires.
using TriggerEvent = std::function<void(const Record& record, std::size_t trigger_index)>;

// Passes every record on to `inner`, calling `on_event` first for each one that fires
// one of `triggers`.
std::unique_ptr<RecordSink> make_trigger_sink(std::vector<Trigger> triggers,
                                              TriggerEvent on_event,
                                              std::unique_ptr<RecordSink> inner);

}  // namespace rtuscope
