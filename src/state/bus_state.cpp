#include "state/bus_state.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <fmt/format.h>

#include "profiles/values.hpp"

namespace rtuscope {

SlotIndex::SlotIndex(std::size_t capacity) : entries_(std::bit_ceil(capacity * 2)) {}

std::size_t SlotIndex::home(std::uint32_t key) const {
    // Fibonacci hashing of all but the address's last 4 bits, which place the key within
    // a run of 16 entries: a block of registers read together shares cache lines.
    const std::size_t run = ((key >> 4) * 0x9E3779B1U) >> 8;
    return ((run << 4) | (key & 15U)) & (entries_.size() - 1);
}

std::uint32_t SlotIndex::find(std::uint32_t key) const {
    for (std::size_t i = home(key);; i = (i + 1) & (entries_.size() - 1)) {
        const Entry& e = entries_[i];
        if (e.slot == kNone || e.key == key) return e.slot;
    }
}

void SlotIndex::insert(std::uint32_t key, std::uint32_t slot) {
    std::size_t i = home(key);
    while (entries_[i].slot != kNone) i = (i + 1) & (entries_.size() - 1);
    entries_[i] = {key, slot};
    ++size_;
}

void SlotIndex::erase(std::uint32_t key) {
    const std::size_t mask = entries_.size() - 1;
    std::size_t hole = home(key);
    while (entries_[hole].slot != kNone && entries_[hole].key != key) hole = (hole + 1) & mask;
    if (entries_[hole].slot == kNone) return;
    --size_;
    // Backward shift: an entry after the hole moves into it unless its home lies
    // between the hole and itself (cyclically), so that every probe still finds it.
    for (std::size_t next = (hole + 1) & mask; entries_[next].slot != kNone;
         next = (next + 1) & mask) {
        const std::size_t want = home(entries_[next].key);
        const bool stays = hole <= next ? (hole < want && want <= next)
                                        : (hole < want || want <= next);
        if (stays) continue;
        entries_[hole] = entries_[next];
        hole = next;
    }
    entries_[hole] = Entry{};
}

void RecentDurations::add(Nanos value) {
    values_[next_] = value;
    next_ = (next_ + 1) % kSize;
    if (size_ < kSize) ++size_;
}

std::optional<Nanos> RecentDurations::percentile(unsigned percent) const {
    if (size_ == 0) return std::nullopt;
    sorted_.assign(values_.begin(), values_.begin() + static_cast<std::ptrdiff_t>(size_));
    const std::size_t rank = (percent * size_ + 99) / 100;  // ceil, at least 1 for p > 0
    const std::size_t i = rank == 0 ? 0 : rank - 1;
    std::nth_element(sorted_.begin(), sorted_.begin() + static_cast<std::ptrdiff_t>(i),
                     sorted_.end());
    return sorted_[i];
}

namespace {
// Whole seconds, rounded down: a capture's first frame may start before its time 0.
std::int64_t second_of(Nanos t) { return floor_div(t, kNanosPerSecond); }
std::size_t bucket_of(std::int64_t second) {
    return static_cast<std::size_t>(floor_mod(second, static_cast<std::int64_t>(PerSecond::kSeconds)));
}
}  // namespace

void PerSecond::add(Nanos at, std::uint32_t n) {
    if (!has_time(at)) return;
    const std::int64_t s = second_of(at);
    if (!started_ || s > last_second_) {
        // Seconds that passed with nothing are emptied (all of them after a long pause).
        const std::int64_t from = !started_ ? s : last_second_ + 1;
        for (std::int64_t k = std::max(from, s - static_cast<std::int64_t>(kSeconds) + 1);
             k <= s; ++k) {
            counts_[bucket_of(k)] = 0;
        }
        last_second_ = s;
        started_ = true;
    } else if (s <= last_second_ - static_cast<std::int64_t>(kSeconds)) {
        return;  // older than the window (the capture's clock went back)
    }
    counts_[bucket_of(s)] += n;
}

std::uint64_t PerSecond::within(Nanos now, std::size_t seconds) const {
    if (!started_ || !has_time(now)) return 0;
    const std::int64_t s = second_of(now);
    std::uint64_t sum = 0;
    for (std::size_t k = 0; k < std::min(seconds, kSeconds); ++k) {
        const std::int64_t second = s - static_cast<std::int64_t>(k);
        if (second > last_second_ || second <= last_second_ - static_cast<std::int64_t>(kSeconds)) {
            continue;
        }
        sum += counts_[bucket_of(second)];
    }
    return sum;
}

void PerSecond::clear() {
    counts_ = {};
    started_ = false;
}

void BusState::begin(const SessionInfo& session) { stats_.begin(session); }

std::optional<BusState::Rates> BusState::recent_rates(Nanos now) const {
    const Nanos first = stats_.bus().first_start;
    if (!has_time(now) || !has_time(first)) return std::nullopt;
    const double seconds = std::clamp(static_cast<double>(now - first) / 1e9, 1.0,
                                      static_cast<double>(PerSecond::kSeconds));
    const auto window = static_cast<std::size_t>(std::ceil(seconds));
    const double bytes = static_cast<double>(bytes_.within(now, window));
    const double busy =
        bytes * static_cast<double>(stats_.session().line.char_time()) / 1e9 / seconds;
    return Rates{static_cast<double>(frames_.within(now, window)) / seconds,
                 std::min(busy, 1.0)};
}

FunctionStats BusState::figures(std::uint8_t slave) const {
    FunctionStats sum;
    const auto& rows = stats_.functions();
    for (auto it = rows.lower_bound({slave, 0}); it != rows.end() && it->first.first == slave;
         ++it) {
        add_function_counts(sum, it->second);
    }
    return sum;
}

std::vector<const SlaveState*> BusState::slaves() const {
    std::vector<const SlaveState*> out;
    for (const auto& s : slaves_) {
        if (s) out.push_back(&*s);
    }
    return out;
}

const SlaveState* BusState::slave(std::uint8_t address) const {
    return slaves_[address] ? &*slaves_[address] : nullptr;
}

std::vector<const RegisterState*> BusState::registers(std::uint8_t slave) const {
    std::vector<const RegisterState*> out;
    for (std::size_t slot = 0; slot < slot_keys_.size(); ++slot) {
        if (slot_keys_[slot] >> 24 != slave) continue;
        const RegisterState& r = slots_[slot];
        if (r.raw_words > 0) out.push_back(&r);
    }
    std::sort(out.begin(), out.end(), [](const RegisterState* a, const RegisterState* b) {
        return a->key.packed() < b->key.packed();
    });
    return out;
}

const RegisterWrite* BusState::write(const RegisterState& r) const {
    if (!r.written) return nullptr;
    const auto it = writes_.find(static_cast<std::uint32_t>(&r - slots_.data()));
    return it == writes_.end() ? nullptr : &it->second;
}

const RegisterState* BusState::find(RegisterKey key) const {
    const std::uint32_t slot = index_.find(key.packed());
    return slot == SlotIndex::kNone ? nullptr : &slots_[slot];
}

std::string_view BusState::table_name(std::uint8_t table) const {
    if (table >= kFirstCustomTable) return custom_tables_[table - kFirstCustomTable];
    switch (static_cast<DataTable>(table)) {
        case DataTable::coils:
            return "coil";
        case DataTable::discrete_inputs:
            return "discrete";
        case DataTable::input_registers:
            return "input";
        case DataTable::holding_registers:
        case DataTable::none:
            break;
    }
    return "holding";
}

void BusState::reset() {
    const SessionInfo session = stats_.session();
    stats_ = BusStats{};
    stats_.begin(session);
    for (auto& s : slaves_) {
        if (!s) continue;
        s->writes = 0;
        s->turnarounds.clear();
        s->requests.clear();
    }
    for (RegisterState& r : slots_) {
        r.changes = 0;
        r.history.clear();
        if (r.numeric) r.history.add(r.min = r.max = std::strtof(r.value.c_str(), nullptr));
    }
    frames_.clear();
    bytes_.clear();
    errors_.clear();
    anomaly_count_ = 0;
}

SlaveState& BusState::slave_of(std::uint8_t address, Nanos at, const Profile* profile) {
    auto& s = slaves_[address];
    if (!s) {
        s.emplace();
        s->address = address;
        s->first_seen = at;
    }
    if (profile != nullptr) s->profile = profile;
    if (has_time(at)) {
        if (!has_time(s->first_seen)) s->first_seen = at;
        s->last_seen = at;
    }
    return *s;
}

std::uint16_t BusState::intern(std::string_view text) {
    scratch_.assign(text);
    if (auto it = text_ids_.find(scratch_); it != text_ids_.end()) return it->second;
    // Names and units come from profiles: a few thousand at most. Beyond the ids there
    // are, a register shows no name rather than a wrong one.
    if (texts_.size() > 0xFFFF) return 0;
    const auto id = static_cast<std::uint16_t>(texts_.size());
    texts_.push_back(scratch_);
    text_ids_.emplace(scratch_, id);
    return id;
}

std::uint8_t BusState::table_id(const DataBlock& block) {
    if (block.custom_table.empty()) return static_cast<std::uint8_t>(block.table);
    const auto it = std::find(custom_tables_.begin(), custom_tables_.end(), block.custom_table);
    if (it != custom_tables_.end()) {
        return static_cast<std::uint8_t>(kFirstCustomTable + (it - custom_tables_.begin()));
    }
    if (custom_tables_.size() >= 255U - kFirstCustomTable) return 255;  // shares the last
    custom_tables_.push_back(block.custom_table);
    return static_cast<std::uint8_t>(kFirstCustomTable + custom_tables_.size() - 1);
}

void BusState::touch(std::uint32_t slot) {
    if (slot == newest_ && !slots_.empty()) return;
    unlink(slot);
    RegisterState& r = slots_[slot];
    r.older = newest_;
    r.newer = SlotIndex::kNone;
    if (newest_ != SlotIndex::kNone) slots_[newest_].newer = slot;
    newest_ = slot;
    if (oldest_ == SlotIndex::kNone) oldest_ = slot;
}

void BusState::unlink(std::uint32_t slot) {
    RegisterState& r = slots_[slot];
    if (r.older != SlotIndex::kNone) slots_[r.older].newer = r.newer;
    if (r.newer != SlotIndex::kNone) slots_[r.newer].older = r.older;
    if (oldest_ == slot) oldest_ = r.newer;
    if (newest_ == slot) newest_ = r.older;
    r.older = r.newer = SlotIndex::kNone;
}

std::uint32_t BusState::slot_for(RegisterKey key) {
    const std::uint32_t packed = key.packed();
    std::uint32_t slot = index_.find(packed);
    if (slot != SlotIndex::kNone) return slot;
    if (slots_.size() < kMaxRegisters) {
        if (slots_.empty()) oldest_ = newest_ = SlotIndex::kNone;
        slot = static_cast<std::uint32_t>(slots_.size());
        slots_.emplace_back();
        slot_keys_.push_back(packed);
        slots_.back().older = slots_.back().newer = SlotIndex::kNone;
    } else {
        // The register not updated for the longest gives its slot (and buffers) up.
        slot = oldest_;
        unlink(slot);
        index_.erase(slots_[slot].key.packed());
        if (slots_[slot].written) writes_.erase(slot);
        ++forgotten_;
        std::string value = std::move(slots_[slot].value);
        slots_[slot] = RegisterState{};
        slots_[slot].value = std::move(value);
        slots_[slot].older = slots_[slot].newer = SlotIndex::kNone;
    }
    slots_[slot].key = key;
    slot_keys_[slot] = packed;
    index_.insert(packed, slot);
    return slot;
}

namespace {

std::optional<float> number_of(std::string_view text) {
    double v = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
    return static_cast<float>(v);
}

}  // namespace

std::uint32_t BusState::update(RegisterKey key, std::string_view name, std::string_view unit,
                      std::string_view value, std::string_view raw, Nanos at,
                      const Record& record, bool write) {
    const std::uint32_t slot = slot_for(key);
    touch(slot);
    updated_.push_back(slot);
    RegisterState& r = slots_[slot];
    r.name = intern(name);
    r.unit = intern(unit);
    const bool first = r.raw_words == 0;
    if (!first && r.value != value) {
        ++r.changes;
        r.last_change = at;
    } else if (first) {
        r.last_change = at;
    }
    r.value.assign(value);
    r.last_update = at;
    // "0x089D 0x0000": the words, of which the first two are kept.
    r.raw_words = 0;
    r.raw = {};
    for (std::size_t i = 0; i < raw.size();) {
        const std::size_t end = std::min(raw.find(' ', i), raw.size());
        std::string_view word = raw.substr(i, end - i);
        if (word.starts_with("0x")) word.remove_prefix(2);
        std::uint16_t w = 0;
        std::from_chars(word.data(), word.data() + word.size(), w, 16);
        if (r.raw_words < r.raw.size()) r.raw[r.raw_words] = w;
        if (r.raw_words < 255) ++r.raw_words;
        i = end + 1;
    }
    if (r.raw_words == 0) r.raw_words = 1;  // a value with no raw words is still a value
    const std::optional<float> number = number_of(value);
    r.numeric = number.has_value();
    const float v = number.value_or(static_cast<float>(r.raw[0]));
    if (first || r.history.size() == 0) {
        r.min = r.max = v;
    } else {
        r.min = std::min(r.min, v);
        r.max = std::max(r.max, v);
    }
    r.history.add(v);
    if (write) {
        r.written = true;
        writes_[slot] = {at, record.number, false};
    }
    return slot;
}

void BusState::take_values(const Record& record, bool write) {
    const std::uint8_t slave = record.frame.slave();
    const Nanos at = record.frame.start;
    std::size_t next_value = 0;
    for (const DataBlock& block : record.decoded.blocks) {
        if (block.write != write) {
            // Values decoded from a block of the other kind are skipped past.
            while (next_value < record.values.size() &&
                   record.values[next_value].address >= block.start &&
                   record.values[next_value].address < block.start + block.values.size()) {
                ++next_value;
            }
            continue;
        }
        const std::uint8_t table = table_id(block);
        if (record.profile == nullptr) {
            for (std::size_t i = 0; i < block.values.size(); ++i) {
                const auto address = static_cast<std::uint16_t>(block.start + i);
                const std::uint16_t word = block.values[i];
                value_text_.clear();
                fmt::format_to(std::back_inserter(value_text_), "{}", word);
                raw_text_.clear();
                fmt::format_to(std::back_inserter(raw_text_), "0x{:04X}", word);
                const std::uint32_t slot = update({slave, table, address}, "", "", value_text_,
                                                  raw_text_, at, record, write);
                if (write) pending_slots_[slave].push_back(slot);
            }
            continue;
        }
        while (next_value < record.values.size()) {
            const DecodedValue& v = record.values[next_value];
            if (v.address < block.start || v.address >= block.start + block.values.size()) break;
            const std::uint32_t slot =
                update({slave, table, v.address}, v.name, v.unit, v.value, v.raw, at, record, write);
            if (write) pending_slots_[slave].push_back(slot);
            ++next_value;
        }
    }
}

void BusState::note_anomaly(const Record& record) {
    std::string& line = anomalies_[anomaly_count_ % kAnomalies];
    ++anomaly_count_;
    line.clear();
    fmt::format_to(std::back_inserter(line), "#{} ", record.number);
    if (record.kind != Kind::noise) {
        fmt::format_to(std::back_inserter(line), "slave {} ", record.frame.slave());
    }
    if (record.kind == Kind::exception) {
        line += record.decoded.summary;
        if (!record.notes.empty()) line += "; ";
    }
    bool first = true;
    for (const Note& n : record.notes) {
        if (!first) line += "; ";
        line += n.text;
        first = false;
    }
}

std::vector<std::string> BusState::anomalies() const {
    std::vector<std::string> out;
    const std::size_t n = std::min(anomaly_count_, kAnomalies);
    for (std::size_t i = anomaly_count_ - n; i < anomaly_count_; ++i) {
        out.push_back(anomalies_[i % kAnomalies]);
    }
    return out;
}

void BusState::add(const Record& record) {
    updated_.clear();
    stats_.add(record);
    const Frame& f = record.frame;
    const Nanos at = f.start;
    if (has_time(at) && (!has_time(last_time_) || at > last_time_)) last_time_ = at;
    bytes_.add(at, static_cast<std::uint32_t>(f.bytes.size()));
    const bool error = record.kind == Kind::invalid || record.kind == Kind::noise ||
                       record.kind == Kind::exception || record.went_unanswered();
    if (error) {
        errors_.add(at);
        note_anomaly(record);
    }
    if (record.kind == Kind::noise) return;
    frames_.add(at);
    const std::uint8_t address = f.slave();
    switch (record.kind) {
        case Kind::request: {
            SlaveState& s = slave_of(address, at, record.profile);
            s.requests.add(at);
            const bool writes =
                std::any_of(record.decoded.blocks.begin(), record.decoded.blocks.end(),
                            [](const DataBlock& b) { return b.write; });
            if (writes) {
                ++s.writes;
                // What it writes shows as written at once, confirmed by the echo.
                pending_slots_[address].clear();
                take_values(record, true);
                pending_request_[address] = record.number;
            }
            return;
        }
        case Kind::broadcast:
            pending_slots_[address].clear();
            take_values(record, true);
            pending_slots_[address].clear();
            return;
        case Kind::response: {
            SlaveState& s = slave_of(address, at, record.profile);
            if (has_time(record.latency)) s.turnarounds.add(record.latency);
            if (record.request_number != 0 && record.request_number == pending_request_[address]) {
                for (const std::uint32_t slot : pending_slots_[address]) {
                    const auto it = writes_.find(slot);  // unless forgotten since
                    if (it != writes_.end() && it->second.by == record.request_number) {
                        it->second.confirmed = true;
                    }
                }
                pending_slots_[address].clear();
                pending_request_[address] = 0;
            }
            take_values(record, false);
            return;
        }
        case Kind::exception:
        case Kind::invalid: {
            if (record.request_number == 0) return;  // a broken frame of nobody's
            SlaveState& s = slave_of(address, at, record.profile);
            if (has_time(record.latency)) s.turnarounds.add(record.latency);
            return;
        }
        case Kind::unknown:
        case Kind::noise:
            return;
    }
}

}  // namespace rtuscope
