#include "output/trigger.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <map>
#include <utility>

#include "framing/note.hpp"
#include "profiles/values.hpp"
#include "util/near_names.hpp"

namespace rtuscope {

namespace {

// Every note id a record can carry (docs/formats.md, Note ids). frame.split_by_length and
// frame.noise are reserved and on no record: a trigger on them would never fire.
constexpr std::array<std::string_view, 27> kNoteIds = {
    note_id::crc_mismatch,         note_id::crc_swapped,
    note_id::truncated,            note_id::gap_inside,
    note_id::short_gap,            note_id::unknown_length,
    note_id::char_error,           note_id::reserved_address,
    note_id::time_backwards,       note_id::cut_by_stop,
    note_id::cut_by_snaplen,       note_id::no_answer,
    note_id::unsolicited,          note_id::unexpected_exception,
    note_id::duplicate_answer,     note_id::stopped_before_answer,
    note_id::byte_count_mismatch,  note_id::malformed,
    note_id::request_mismatch,     note_id::illegal_value,
    note_id::unknown_function,     note_id::over_device_limit,
    note_id::value_out_of_range,   note_id::value_partial,
    note_id::value_unlisted,       note_id::value_read_only,
    note_id::value_write_only,
};

// A number as a term gives it or a value shows it ("250", "-0.5", "1.5e+06"); nothing
// else is one (hex, "inf", trailing text).
std::optional<double> number_in(std::string_view text) {
    double value = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || ec != std::errc{} || ptr != text.data() + text.size() ||
        !std::isfinite(value)) {
        return std::nullopt;
    }
    return value;
}

// What lies between two commas of the expression, spaces trimmed, and its 1-based column.
struct Piece {
    std::string_view text;
    int column = 0;
};

Piece trimmed(std::string_view text, int column) {
    while (!text.empty() && text.front() == ' ') {
        text.remove_prefix(1);
        ++column;
    }
    while (!text.empty() && text.back() == ' ') text.remove_suffix(1);
    return {text, column};
}

Error error_at(int column, const std::string& message) {
    return Error{fmt::format("column {}: {}", column, message), {}, 0, column};
}

// The items of a comma-separated list, in order.
template <typename Each>
void for_each_item(std::string_view list, Each each) {
    while (true) {
        const auto comma = list.find(',');
        each(list.substr(0, comma));
        if (comma == std::string_view::npos) break;
        list.remove_prefix(comma + 1);
    }
}

std::string joined(const std::vector<std::string_view>& names, std::size_t limit = 8) {
    std::string text;
    for (std::size_t i = 0; i < names.size() && i < limit; ++i) {
        if (i > 0) text += ", ";
        text += names[i];
    }
    if (names.size() > limit) text += ", ...";
    return text;
}

Result<TriggerTerm> parse_flags(std::string_view list) {
    FlagTerm term;
    std::optional<Error> error;
    for_each_item(list, [&](std::string_view id) {
        if (error) return;
        const auto known = std::find(kNoteIds.begin(), kNoteIds.end(), id);
        if (known != kNoteIds.end()) {
            term.ids.push_back(*known);  // the table's, which outlives the trigger
            return;
        }
        const std::vector<std::string> near = near_names(id, kNoteIds);
        error = Error{fmt::format("unknown note id \"{}\" ({})", id,
                                  near.empty() ? std::string("the ids are in docs/formats.md, "
                                                             "Note ids")
                                               : fmt::format("did you mean {}?",
                                                             fmt::join(near, ", ")))};
    });
    if (error) return *error;
    return TriggerTerm{std::move(term)};
}

Result<TriggerTerm> parse_crc(std::string_view list) {
    static constexpr std::array kStatuses = {CrcStatus::ok, CrcStatus::bad, CrcStatus::swapped};
    CrcTerm term;
    std::optional<Error> error;
    for_each_item(list, [&](std::string_view word) {
        if (error) return;
        const auto status = std::find_if(kStatuses.begin(), kStatuses.end(),
                                         [&](CrcStatus s) { return to_string(s) == word; });
        if (status == kStatuses.end()) {
            error = Error{fmt::format("unknown CRC state \"{}\" (ok, bad, swapped)", word)};
            return;
        }
        term.statuses.push_back(*status);
    });
    if (error) return *error;
    return TriggerTerm{std::move(term)};
}

template <typename T, typename Set>
Result<TriggerTerm> filter_term(Result<T> list, Set set) {
    if (!list) return list.error();
    RecordFilter filter;
    set(filter, std::move(*list));
    return TriggerTerm{std::move(filter)};
}

// The terms of their own; every other name is a register's.
struct Keyword {
    std::string_view name;
    std::string_view example;  // for messages
    Result<TriggerTerm> (*parse)(std::string_view list);
};

constexpr std::array<Keyword, 5> kKeywords = {{
    {"kind", "kind=request,exception",
     [](std::string_view list) {
         return filter_term(parse_kinds(list),
                            [](RecordFilter& f, std::vector<std::string> v) { f.kinds = std::move(v); });
     }},
    {"slave", "slave=1,3,10-20",
     [](std::string_view list) {
         return filter_term(parse_ranges(list, 255),
                            [](RecordFilter& f, RecordFilter::Ranges v) { f.slaves = std::move(v); });
     }},
    {"function", "function=3,0x10",
     [](std::string_view list) {
         return filter_term(parse_ranges(list, 127), [](RecordFilter& f, RecordFilter::Ranges v) {
             f.functions = std::move(v);
         });
     }},
    {"flag", "flag=txn.no_answer", parse_flags},
    {"crc", "crc=bad", parse_crc},
}};

const Keyword* keyword_named(std::string_view name) {
    const auto k = std::find_if(kKeywords.begin(), kKeywords.end(),
                                [&](const Keyword& kw) { return kw.name == name; });
    return k == kKeywords.end() ? nullptr : &*k;
}

struct OpSpelling {
    std::string_view text;
    ValueTerm::Op op;
};
// Two-character spellings first: "<=" is not "<" followed by "=5".
constexpr std::array<OpSpelling, 5> kOps = {{{"<=", ValueTerm::Op::less_equal},
                                             {">=", ValueTerm::Op::greater_equal},
                                             {"=", ValueTerm::Op::equal},
                                             {"<", ValueTerm::Op::less},
                                             {">", ValueTerm::Op::greater}}};
constexpr std::string_view kOpChars = "<>=";

// What the registers of one name show across the loaded profiles, to check a term's
// values against.
struct RegisterKinds {
    bool numbers = false;   // some is a number type (u16 ... f32)
    bool labelled = false;  // some is an enum: its labels, and numbers it has no label for
    bool any_text = false;  // some is bits or a string: any text may be shown
    std::vector<std::string_view> labels;  // enum labels and the meanings of special writes
};

class Names {
  public:
    explicit Names(const TriggerContext& context) {
        for (const Profile* profile : context.profiles) {
            profiles_.push_back(profile->name);
            for (const Register& reg : profile->registers) {
                RegisterKinds& kinds = registers_[reg.name];
                if (reg.type == ValueType::enumeration) {
                    kinds.labelled = true;
                    for (const auto& [raw, label] : reg.labels) kinds.labels.push_back(label);
                } else if (is_numeric(reg.type)) {
                    kinds.numbers = true;
                } else {
                    kinds.any_text = true;  // bit names, text
                }
                for (const auto& [raw, meaning] : reg.writes) kinds.labels.push_back(meaning);
            }
        }
        for (const Keyword& k : kKeywords) all_.push_back(k.name);
        for (const auto& [name, kinds] : registers_) all_.push_back(name);
    }

    [[nodiscard]] const RegisterKinds* find(std::string_view name) const {
        const auto r = registers_.find(name);
        return r == registers_.end() ? nullptr : &r->second;
    }
    [[nodiscard]] bool is_term_name(std::string_view name) const {
        return keyword_named(name) != nullptr || find(name) != nullptr;
    }

    // `name` is neither a keyword nor a register of the loaded profiles.
    [[nodiscard]] std::string unknown(std::string_view name) const {
        const std::vector<std::string> near = near_names(name, all_);
        if (!near.empty()) {
            return fmt::format("unknown term \"{}\" (did you mean {}?)", name, fmt::join(near, ", "));
        }
        if (profiles_.empty()) {
            return fmt::format(
                "unknown term \"{}\" (kind, slave, function, flag, crc; a register's name needs "
                "its device's profile: --device ADDR=PROFILE or --bus FILE)",
                name);
        }
        return fmt::format(
            "unknown term \"{}\" (kind, slave, function, flag, crc, or a register of {})", name,
            joined(profiles_));
    }

  private:
    std::map<std::string, RegisterKinds, std::less<>> registers_;
    std::vector<std::string_view> profiles_;
    std::vector<std::string_view> all_;  // keywords and register names, for suggestions
};

// One term as written: NAME OP VALUE, and the items after further commas that continue
// its list.
struct TermText {
    Piece name;
    OpSpelling op;
    int op_column = 0;
    std::vector<Piece> items;  // the value, then each further item of its list
};

// A keyword's list: parsed whole by the list's own parser, which is the one --slave,
// --kind ... use. An error points at the first item that is wrong by itself.
Result<TriggerTerm> keyword_term(const Keyword& keyword, const TermText& t, const Names& names) {
    std::string list;
    for (const Piece& item : t.items) {
        if (!list.empty()) list += ',';
        list += item.text;
    }
    Result<TriggerTerm> term = keyword.parse(list);
    if (term) return term;
    for (const Piece& item : t.items) {
        const Result<TriggerTerm> alone = keyword.parse(item.text);
        if (alone) continue;
        if (&item != t.items.data() && names.is_term_name(item.text)) {
            return error_at(item.column, fmt::format("\"{}\" needs a value ({}=...)", item.text,
                                                     item.text));
        }
        return error_at(item.column, alone.error().message);
    }
    return error_at(t.items.front().column, term.error().message);
}

Result<TriggerTerm> value_term(const RegisterKinds& kinds, const TermText& t) {
    ValueTerm term;
    term.name = std::string(t.name.text);
    term.op = t.op.op;
    if (term.op != ValueTerm::Op::equal) {
        if (t.items.size() > 1) {
            return error_at(t.items[1].column, fmt::format("{}{} takes one number, not a list",
                                                           t.name.text, t.op.text));
        }
        const Piece& value = t.items.front();
        const std::optional<double> number = number_in(value.text);
        if (!number) {
            return error_at(value.column, fmt::format("\"{}\" is not a number ({}{}250)",
                                                      value.text, t.name.text, t.op.text));
        }
        if (!kinds.numbers) {
            return error_at(t.op_column,
                            fmt::format("{} shows no numbers (labels, bits or text): compare "
                                        "it with =",
                                        t.name.text));
        }
        term.operands.push_back({std::string(value.text), number});
        return TriggerTerm{std::move(term)};
    }
    for (const Piece& value : t.items) {
        const std::optional<double> number = number_in(value.text);
        const bool shown =
            kinds.any_text || (number && (kinds.numbers || kinds.labelled)) ||
            std::find(kinds.labels.begin(), kinds.labels.end(), value.text) != kinds.labels.end();
        if (!shown) {
            return error_at(value.column,
                            kinds.labels.empty()
                                ? fmt::format("\"{}\" is not a number, which {} shows",
                                              value.text, t.name.text)
                                : fmt::format("\"{}\" is not a value of {} ({})", value.text,
                                              t.name.text, joined(kinds.labels)));
        }
        term.operands.push_back({std::string(value.text), number});
    }
    return TriggerTerm{std::move(term)};
}

// The pieces grouped into terms: a piece with an operator starts one, any other piece is
// one more item of the list before it.
Result<std::vector<TermText>> group_terms(const std::vector<Piece>& pieces, const Names& names) {
    std::vector<TermText> terms;
    for (std::size_t i = 0; i < pieces.size(); ++i) {
        const Piece& piece = pieces[i];
        if (piece.text.empty()) {
            return error_at(piece.column, i == 0                     ? "nothing before the comma"
                                          : i + 1 == pieces.size() ? "nothing after the comma"
                                                                   : "nothing between two commas");
        }
        const auto at = piece.text.find_first_of(kOpChars);
        if (at == std::string_view::npos) {
            if (!terms.empty()) {
                terms.back().items.push_back(piece);
                continue;
            }
            if (names.is_term_name(piece.text)) {
                return error_at(piece.column, fmt::format("\"{}\" needs a value ({}=...)",
                                                          piece.text, piece.text));
            }
            return error_at(piece.column,
                            fmt::format("\"{}\" is no term (NAME=LIST, NAME<NUMBER, NAME>NUMBER)",
                                        piece.text));
        }
        const std::string_view rest = piece.text.substr(at);
        const auto op = std::find_if(kOps.begin(), kOps.end(), [&](const OpSpelling& o) {
            return rest.starts_with(o.text);
        });
        TermText term;
        term.op = *op;  // the first character is one of kOpChars, each a spelling alone
        term.op_column = piece.column + static_cast<int>(at);
        term.name = trimmed(piece.text.substr(0, at), piece.column);
        const std::size_t value_at = at + op->text.size();
        term.items.push_back(
            trimmed(piece.text.substr(value_at), piece.column + static_cast<int>(value_at)));
        if (term.name.text.empty()) {
            return error_at(piece.column, "a term starts with a name (slave=3, voltage>250)");
        }
        if (term.items.front().text.empty()) {
            return error_at(term.items.front().column,
                            fmt::format("nothing after \"{}{}\"", term.name.text, op->text));
        }
        terms.push_back(std::move(term));
    }
    return terms;
}

}  // namespace

std::span<const std::string_view> known_note_ids() {
    return kNoteIds;
}

TriggerContext trigger_context(const Bus* bus) {
    TriggerContext context;
    if (bus == nullptr) return context;
    for (unsigned address = 0; address <= 255; ++address) {
        const Profile* profile = bus->profile_for(static_cast<std::uint8_t>(address));
        if (profile != nullptr && std::find(context.profiles.begin(), context.profiles.end(),
                                            profile) == context.profiles.end()) {
            context.profiles.push_back(profile);
        }
    }
    return context;
}

Result<Trigger> parse_trigger(std::string_view expr, const TriggerContext& context) {
    if (expr.find_first_not_of(' ') == std::string_view::npos) {
        return error_at(1, "empty expression (e.g. flag=txn.no_answer, slave=3,crc=bad)");
    }
    std::vector<Piece> pieces;
    for (std::size_t from = 0;;) {
        const std::size_t comma = std::min(expr.find(',', from), expr.size());
        pieces.push_back(trimmed(expr.substr(from, comma - from), static_cast<int>(from) + 1));
        if (comma == expr.size()) break;
        from = comma + 1;
    }
    const Names names(context);
    auto texts = group_terms(pieces, names);
    if (!texts) return texts.error();

    Trigger trigger;
    trigger.expression = std::string(expr);
    for (const TermText& t : *texts) {
        Result<TriggerTerm> term = Error{};
        if (const Keyword* keyword = keyword_named(t.name.text)) {
            if (t.op.op != ValueTerm::Op::equal) {
                return error_at(t.op_column, fmt::format("{} takes =, not {} ({})", keyword->name,
                                                         t.op.text, keyword->example));
            }
            term = keyword_term(*keyword, t, names);
        } else if (const RegisterKinds* kinds = names.find(t.name.text)) {
            term = value_term(*kinds, t);
        } else {
            return error_at(t.name.column, names.unknown(t.name.text));
        }
        if (!term) return term.error();
        trigger.terms.push_back(std::move(*term));
    }
    return trigger;
}

namespace {

bool has_note(const Record& r, std::string_view id) {
    return r.notes.has(id) || std::any_of(r.values.begin(), r.values.end(), [&](const auto& v) {
               return v.notes.has(id);
           });
}

bool value_matches(const ValueTerm& term, const DecodedValue& v) {
    if (v.name != term.name) return false;
    const std::optional<double> shown = number_in(v.value);
    if (term.op == ValueTerm::Op::equal) {
        return std::any_of(term.operands.begin(), term.operands.end(), [&](const auto& operand) {
            return operand.number && shown ? *operand.number == *shown : operand.text == v.value;
        });
    }
    if (!shown) return false;
    const double limit = *term.operands.front().number;
    switch (term.op) {
        case ValueTerm::Op::less:
            return *shown < limit;
        case ValueTerm::Op::greater:
            return *shown > limit;
        case ValueTerm::Op::less_equal:
            return *shown <= limit;
        case ValueTerm::Op::greater_equal:
            return *shown >= limit;
        case ValueTerm::Op::equal:
            break;
    }
    return false;
}

struct TermMatcher {
    const Record& r;
    bool operator()(const RecordFilter& filter) const {
        return filter.matches(r, std::nullopt, std::nullopt);
    }
    bool operator()(const FlagTerm& term) const {
        return std::any_of(term.ids.begin(), term.ids.end(),
                           [&](std::string_view id) { return has_note(r, id); });
    }
    bool operator()(const CrcTerm& term) const {
        return std::find(term.statuses.begin(), term.statuses.end(), r.frame.crc.status) !=
               term.statuses.end();
    }
    bool operator()(const ValueTerm& term) const {
        return std::any_of(r.values.begin(), r.values.end(),
                           [&](const DecodedValue& v) { return value_matches(term, v); });
    }
};

}  // namespace

bool Trigger::matches(const Record& record) const {
    return std::all_of(terms.begin(), terms.end(), [&](const TriggerTerm& term) {
        return std::visit(TermMatcher{record}, term);
    });
}

std::optional<std::size_t> first_firing(std::span<const Trigger> triggers, const Record& record) {
    for (std::size_t i = 0; i < triggers.size(); ++i) {
        if (triggers[i].matches(record)) return i;
    }
    return std::nullopt;
}

namespace {

class TriggerSink final : public RecordSink {
  public:
    TriggerSink(std::vector<Trigger> triggers, TriggerEvent on_event,
                std::unique_ptr<RecordSink> inner)
        : triggers_(std::move(triggers)), on_event_(std::move(on_event)), inner_(std::move(inner)) {}
    void begin(const SessionInfo& s) override { inner_->begin(s); }
    void record(const Record& r) override {
        if (const auto fired = first_firing(triggers_, r)) on_event_(r, *fired);
        inner_->record(r);
    }
    void end(const Totals& t, const std::vector<std::string>& remarks) override {
        inner_->end(t, remarks);
    }
    void flush() override { inner_->flush(); }
    void idle(Nanos now) override { inner_->idle(now); }

  private:
    std::vector<Trigger> triggers_;
    TriggerEvent on_event_;
    std::unique_ptr<RecordSink> inner_;
};

}  // namespace

std::unique_ptr<RecordSink> make_trigger_sink(std::vector<Trigger> triggers,
                                              TriggerEvent on_event,
                                              std::unique_ptr<RecordSink> inner) {
    return std::make_unique<TriggerSink>(std::move(triggers), std::move(on_event),
                                         std::move(inner));
}

}  // namespace rtuscope
