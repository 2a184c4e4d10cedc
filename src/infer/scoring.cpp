#include "infer/scoring.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <set>

#include "infer/series.hpp"

namespace rtuscope::infer {
namespace {

using Alternative = RegisterGuess::Alternative;

// Enough samples per distinct value to call a register an enum rather than a quantity
// that happened to take few values.
constexpr std::size_t kSamplesPerEnumValue = 4;
constexpr std::size_t kMaxEnumValues = 8;
// Float readings: this share of the steps under 10 % of the value.
constexpr double kSmoothShare = 0.9;

std::string hex(std::uint16_t v) {
    return fmt::format("0x{:04X}", v);
}

std::string seconds(Nanos t) {
    return fmt::format("{:.3g} s", static_cast<double>(t) / 1e9);
}

std::string value_list(const std::vector<std::uint16_t>& values) {
    std::string out;
    for (std::uint16_t v : values) out += fmt::format("{}{}", out.empty() ? "" : ", ", v);
    return out;
}

Access access_of(bool read, bool written) {
    if (read && written) return Access::read_write;
    return written ? Access::write : Access::read;
}

// What the writes of one register add to its evidence.
void add_write_evidence(RegisterGuess& guess, const WriteSeen* writes) {
    if (writes == nullptr) return;
    std::string functions;
    for (std::uint8_t f : writes->functions) {
        functions += fmt::format("{}FC{:02X}", functions.empty() ? "" : "/", f);
    }
    guess.evidence.push_back(fmt::format("written {} times by {}: {}{}", writes->count, functions,
                                         value_list(writes->values),
                                         writes->values.size() >= kMaxWrittenValues ? ", ..." : ""));
}

bool float_fits(const FloatReading& f) {
    return f.all_sane && f.varies && f.smooth_fraction >= kSmoothShare &&
           f.low_word_changes >= f.high_word_changes;
}

std::string float_evidence(const FloatReading& f, const char* order) {
    if (!f.all_sane) return fmt::format("as f32 {}: not finite or absurd exponents", order);
    return fmt::format("as f32 {}: {:.6g}..{:.6g}, {:.0f} % of steps under 10 %", order, f.min,
                       f.max, 100.0 * f.smooth_fraction);
}

// Two registers always read together, read as one value of 32 bits; nullopt when the
// values give no reason to join them.
std::optional<RegisterGuess> guess_pair(const PairSeries& pair) {
    const FloatReading abcd = read_floats(pair, HighWord::first);
    const FloatReading cdab = read_floats(pair, HighWord::second);
    RegisterGuess g;
    g.length = 2;
    if (float_fits(abcd) != float_fits(cdab)) {
        const bool first_high = float_fits(abcd);
        g.type = ValueType::f32;
        g.word_order = first_high ? WordOrder::abcd : WordOrder::cdab;
        g.confidence = pair.first.size() >= 10 ? Confidence::high : Confidence::medium;
        g.evidence.push_back(float_evidence(first_high ? abcd : cdab, first_high ? "abcd" : "cdab"));
        g.evidence.push_back(float_evidence(first_high ? cdab : abcd, first_high ? "cdab" : "abcd"));
        return g;
    }
    const CarryCount high_first = count_carries(pair, HighWord::first);
    const CarryCount high_second = count_carries(pair, HighWord::second);
    const auto carries_only = [](const CarryCount& c, const CarryCount& other) {
        return c.carries > 0 && c.unexplained_high_steps == 0 && other.carries == 0;
    };
    HighWord high = HighWord::first;
    if (carries_only(high_first, high_second)) {
        high = HighWord::first;
    } else if (carries_only(high_second, high_first)) {
        high = HighWord::second;
    } else {
        return std::nullopt;
    }
    const CarryCount& carry = high == HighWord::first ? high_first : high_second;
    g.word_order = high == HighWord::first ? WordOrder::abcd : WordOrder::cdab;
    const std::vector<std::uint32_t> values = join_words(pair, high);
    const SignedSteps steps = signed_steps32(values);
    const bool wraps_zero = steps.has_negative && steps.has_positive &&
                            steps.max_step_unsigned >= 0x80000000U &&
                            steps.max_step_signed < 0x40000000U;
    g.type = wraps_zero ? ValueType::i32 : ValueType::u32;
    g.confidence = carry.carries >= 2 ? Confidence::high : Confidence::medium;
    g.evidence.push_back(fmt::format(
        "{} {} between the words: the {} register is the high word", carry.carries,
        carry.carries == 1 ? "carry or borrow" : "carries or borrows",
        high == HighWord::first ? "first" : "second"));
    if (wraps_zero) {
        g.evidence.push_back("crosses zero with small steps as i32");
    } else if (!steps.has_negative) {
        g.alternatives.push_back({ValueType::i32, g.word_order});
        g.evidence.push_back("ambiguous: u32 or i32 (never above 0x7FFFFFFF)");
    }
    if (std::is_sorted(values.begin(), values.end()) && values.front() != values.back()) {
        g.counter = true;
        g.evidence.push_back("only ever increases: a counter (total_increasing)");
    }
    return g;
}

void add_scale_hints(RegisterGuess& g, const WordSeries& s) {
    if (s.constant() || s.min == s.max) return;
    if (s.multiples_of_100) {
        g.evidence.push_back("hint: every value a multiple of 100");
    } else if (s.multiples_of_10) {
        g.evidence.push_back("hint: every value a multiple of 10");
    }
    if (g.type == ValueType::u16 && s.min >= 1800 && s.max <= 2600) {
        g.evidence.push_back("hint: reads like a mains voltage in tenths (decimals = 1)");
    }
    if (g.type == ValueType::i16 && s.max_step_signed <= 50) {
        g.evidence.push_back("hint: small steps across zero, like a temperature in tenths "
                             "(decimals = 1)");
    }
}

RegisterGuess guess_word(const std::vector<Sample>& samples) {
    const WordSeries s = measure_word(samples);
    RegisterGuess g;
    g.evidence.push_back(fmt::format("{} reads, {}{}..{} ({})", s.samples, "values ", s.min, s.max,
                                     s.many_values() ? "many distinct"
                                                     : fmt::format("{} distinct", s.distinct.size())));
    const auto fits_i16_too = [&] {
        if (!s.above_sign) {
            g.alternatives.push_back({ValueType::i16, WordOrder::abcd});
            g.evidence.push_back("ambiguous: u16 or i16 (never above 0x7FFF)");
        }
    };
    if (s.constant()) {
        g.constant = true;
        g.confidence = Confidence::low;
        g.evidence.front() = fmt::format("constant {} ({}) in {} reads", hex(s.min), s.min, s.samples);
        for (ValueType t : {ValueType::i16, ValueType::enumeration, ValueType::bits}) {
            g.alternatives.push_back({t, WordOrder::abcd});
        }
        g.evidence.push_back("ambiguous: any 16-bit type reads a constant");
        return g;
    }
    const bool wraps_zero =
        s.below_sign && s.above_sign && s.max_step_unsigned >= 0x8000 && s.max_step_signed < 0x4000;
    if (wraps_zero) {
        g.type = ValueType::i16;
        g.confidence = Confidence::high;
        g.evidence.push_back(fmt::format(
            "wraps around 0: as i16 {}..{}, steps of at most {} (as u16 {})",
            static_cast<std::int16_t>(s.max), static_cast<std::int16_t>(s.min), s.max_step_signed,
            s.max_step_unsigned));
        add_scale_hints(g, s);
        return g;
    }
    const std::size_t distinct = s.distinct.size();
    if (!s.many_values() && distinct >= 3 && s.single_bit_changes &&
        std::popcount(s.toggled_bits) >= 2) {
        g.type = ValueType::bits;
        g.confidence = Confidence::medium;
        for (unsigned bit = 0; bit < 16; ++bit) {
            if ((s.toggled_bits >> bit) & 1U) g.labels.push_back(static_cast<std::uint16_t>(bit));
        }
        g.evidence.push_back(fmt::format("a bit field: every change flips one bit; bits {} toggle",
                                         value_list(g.labels)));
        g.alternatives.push_back({ValueType::u16, WordOrder::abcd});
        g.alternatives.push_back({ValueType::enumeration, WordOrder::abcd});
        return g;
    }
    if (!s.many_values() && distinct <= kMaxEnumValues &&
        s.samples >= kSamplesPerEnumValue * distinct && !s.non_decreasing) {
        g.type = ValueType::enumeration;
        g.confidence = Confidence::medium;
        g.labels = s.distinct;
        g.evidence.push_back(fmt::format("an enum: only the values {}", value_list(s.distinct)));
        g.alternatives.push_back({ValueType::u16, WordOrder::abcd});
        if (!s.above_sign) g.alternatives.push_back({ValueType::i16, WordOrder::abcd});
        if (s.single_bit_changes) g.alternatives.push_back({ValueType::bits, WordOrder::abcd});
        return g;
    }
    g.confidence = Confidence::medium;
    if (s.non_decreasing) {
        g.counter = true;
        g.evidence.push_back("only ever increases: a counter (total_increasing)");
    }
    if (s.above_sign && !s.below_sign) {
        // Every value has the sign bit: large unsigned numbers or small negative ones.
        g.type = s.min >= 0xF000 ? ValueType::i16 : ValueType::u16;
        g.alternatives.push_back(
            {g.type == ValueType::i16 ? ValueType::u16 : ValueType::i16, WordOrder::abcd});
        g.evidence.push_back(fmt::format("ambiguous: u16 or i16 (always above 0x7FFF{})",
                                         g.type == ValueType::i16 ? "; small as i16" : ""));
    } else {
        fits_i16_too();
    }
    add_scale_hints(g, s);
    return g;
}

RegisterGuess guess_bit(const std::vector<Sample>& samples) {
    const WordSeries s = measure_word(samples);
    RegisterGuess g;
    g.alternatives.push_back({ValueType::enumeration, WordOrder::abcd});
    if (s.constant()) {
        g.constant = true;
        g.confidence = Confidence::low;
        g.evidence.push_back(fmt::format("constant {} in {} reads", s.min, s.samples));
    } else {
        g.confidence = Confidence::medium;
        g.evidence.push_back(fmt::format("{} reads, changes {} times", s.samples, s.changes));
    }
    return g;
}

// The words of a 32-bit value whose high word never moved look like a constant beside a
// 16-bit quantity: both readings stay open.
void add_pair_alternatives(RegisterGuess& first, RegisterGuess& second, const PairSeries& pair) {
    const auto zero_or_ones = [](const RegisterGuess& g, const std::vector<std::uint16_t>& words) {
        return g.constant && (words.front() == 0 || words.front() == 0xFFFF);
    };
    if (zero_or_ones(first, pair.first) && !second.constant) {
        first.alternatives.push_back({ValueType::u32, WordOrder::abcd});
        first.alternatives.push_back({ValueType::i32, WordOrder::abcd});
        first.evidence.push_back("perhaps the high word of a 32-bit value with the next "
                                 "register (read together, no carry seen)");
    } else if (zero_or_ones(second, pair.second) && !first.constant) {
        first.alternatives.push_back({ValueType::u32, WordOrder::cdab});
        first.alternatives.push_back({ValueType::i32, WordOrder::cdab});
        first.evidence.push_back("perhaps the low word of a 32-bit value with the next register "
                                 "(read together, no carry seen)");
    } else if (first.constant && second.constant) {
        for (auto [high, order] : {std::pair(HighWord::first, WordOrder::abcd),
                                   std::pair(HighWord::second, WordOrder::cdab)}) {
            const FloatReading f = read_floats(pair, high);
            const FloatReading other =
                read_floats(pair, high == HighWord::first ? HighWord::second : HighWord::first);
            if (f.all_sane && f.min != 0 && !other.all_sane) {
                first.alternatives.push_back({ValueType::f32, order});
                first.evidence.push_back(fmt::format(
                    "perhaps an f32 {} with the next register: {:.6g}", reading_name(ValueType::f32, order)
                        .substr(4), f.min));
            }
        }
    }
}

}  // namespace

const char* confidence_name(Confidence confidence) {
    switch (confidence) {
        case Confidence::low:
            return "low";
        case Confidence::medium:
            return "medium";
        case Confidence::high:
            return "high";
    }
    return "";
}

std::string reading_name(ValueType type, WordOrder order) {
    if (!is_multi_register(type)) return value_type_name(type);
    const char* orders[] = {"abcd", "cdab", "badc", "dcba"};
    return fmt::format("{} {}", value_type_name(type), orders[static_cast<int>(order)]);
}

bool RegisterGuess::accepts(ValueType t, WordOrder order) const {
    const auto same = [&](ValueType candidate, WordOrder candidate_order) {
        return candidate == t && (!is_multi_register(t) || candidate_order == order);
    };
    if (same(type, word_order)) return true;
    return std::any_of(alternatives.begin(), alternatives.end(),
                       [&](const Alternative& a) { return same(a.type, a.word_order); });
}

DeviceGuess infer_device(const SlaveTraffic& traffic) {
    DeviceGuess device;
    device.slave = traffic.slave;
    device.answered_reads = traffic.answered_reads;
    for (const ReadBlock& b : traffic.blocks) {
        const Nanos period = median_period(b.times);
        device.poll_map.push_back(fmt::format(
            "FC{:02X} {} {}-{} ({} {}): {} polls{}", b.function, table_name(b.table), hex(b.start),
            hex(static_cast<std::uint16_t>(b.start + b.count - 1)), b.count,
            is_bit_table(b.table) ? (b.count == 1 ? "bit" : "bits")
                                  : (b.count == 1 ? "register" : "registers"),
            b.polls,
            has_time(period) ? ", every " + seconds(period) + " (median)" : std::string()));
    }
    for (const auto& [key, w] : traffic.writes) {
        std::string functions;
        for (std::uint8_t f : w.functions) functions += fmt::format("{}FC{:02X}", functions.empty() ? "" : "/", f);
        device.poll_map.push_back(fmt::format("{} {} {}: written {} times, values {}", functions,
                                              table_name(key.table), hex(key.address), w.count,
                                              value_list(w.values)));
    }

    std::set<RegisterKey> keys;
    for (const auto& entry : traffic.reads) keys.insert(entry.first);
    for (const auto& entry : traffic.writes) keys.insert(entry.first);
    std::set<RegisterKey> taken;
    const auto samples_of = [&](const RegisterKey& key) -> const std::vector<Sample>* {
        auto it = traffic.reads.find(key);
        return it == traffic.reads.end() ? nullptr : &it->second;
    };
    const auto writes_of = [&](const RegisterKey& key) -> const WriteSeen* {
        auto it = traffic.writes.find(key);
        return it == traffic.writes.end() ? nullptr : &it->second;
    };
    // Single words whose neighbour was read with them: checked again once both are typed.
    std::vector<std::pair<std::size_t, PairSeries>> neighbours;
    for (const RegisterKey& key : keys) {
        if (taken.contains(key)) continue;
        const std::vector<Sample>* samples = samples_of(key);
        const RegisterKey next{key.table, static_cast<std::uint16_t>(key.address + 1)};
        const std::vector<Sample>* next_samples =
            key.address < 0xFFFF && !taken.contains(next) ? samples_of(next) : nullptr;
        std::optional<PairSeries> pair;
        if (samples != nullptr && next_samples != nullptr && !is_bit_table(key.table)) {
            pair = read_together(*samples, *next_samples);
        }
        RegisterGuess g;
        if (pair) {
            if (auto joined = guess_pair(*pair)) {
                g = std::move(*joined);
                taken.insert(next);
                g.access = access_of(true, writes_of(key) != nullptr || writes_of(next) != nullptr);
                g.table = key.table;
                g.address = key.address;
                add_write_evidence(g, writes_of(key));
                add_write_evidence(g, writes_of(next));
                device.registers.push_back(std::move(g));
                continue;
            }
            neighbours.emplace_back(device.registers.size(), std::move(*pair));
        }
        if (samples == nullptr) {
            g.confidence = Confidence::low;
            g.evidence.push_back("written only: the values read tell nothing of its type");
            if (!is_bit_table(key.table)) {
                for (ValueType t : {ValueType::i16, ValueType::enumeration, ValueType::bits}) {
                    g.alternatives.push_back({t, WordOrder::abcd});
                }
            }
        } else {
            g = is_bit_table(key.table) ? guess_bit(*samples) : guess_word(*samples);
        }
        g.table = key.table;
        g.address = key.address;
        g.access = access_of(samples != nullptr, writes_of(key) != nullptr);
        add_write_evidence(g, writes_of(key));
        device.registers.push_back(std::move(g));
    }
    for (const auto& [index, pair] : neighbours) {
        if (index + 1 >= device.registers.size()) continue;
        RegisterGuess& first = device.registers[index];
        RegisterGuess& second = device.registers[index + 1];
        if (second.address != first.address + 1 || second.length != 1) continue;
        add_pair_alternatives(first, second, pair);
    }
    return device;
}

}  // namespace rtuscope::infer
