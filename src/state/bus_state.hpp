// Stage 5b, the bus's state: what a dashboard (`rtuscope watch`) or a telemetry exporter
// shows of the bus at any moment, built from the pipeline's records. Per slave: its
// profile, when it was first and last seen, its counters (the very counters of `stats`:
// BusStats' rows of that slave, summed), its recent turnarounds and poll rate. Per
// register or bit: its current value with name and unit, when it last changed, its
// minimum and maximum, its last 32 values, and who last wrote it.
//
// Memory is bounded whatever the run's length: at most kMaxRegisters registers (the one
// not updated for the longest is forgotten for a new one, and counted), fixed-size windows
// per slave. Updating costs O(1) per value and allocates nothing per record once every
// register has been seen (values longer than a string's inline room aside).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "stats/bus_stats.hpp"

namespace rtuscope {

// A register or bit: slave, table, address. Tables beyond the four standard ones are a
// device's own (a profile's function code), numbered as they come.
struct RegisterKey {
    std::uint8_t slave = 0;
    std::uint8_t table = 0;  // DataTable, or kFirstCustomTable + n
    std::uint16_t address = 0;

    [[nodiscard]] std::uint32_t packed() const {
        return (std::uint32_t{slave} << 24) | (std::uint32_t{table} << 16) | address;
    }
    bool operator==(const RegisterKey&) const = default;
};

// Recent values of a register, oldest first when read with at().
class ValueHistory {
  public:
    static constexpr std::size_t kSize = 32;
    void add(float value) {
        values_[next_] = value;
        next_ = static_cast<std::uint8_t>((next_ + 1) % kSize);
        if (size_ < kSize) ++size_;
    }
    [[nodiscard]] std::size_t size() const { return size_; }
    [[nodiscard]] float at(std::size_t i) const {
        return values_[(next_ + kSize - size_ + i) % kSize];
    }
    void clear() { size_ = next_ = 0; }

  private:
    std::array<float, kSize> values_{};
    std::uint8_t size_ = 0;
    std::uint8_t next_ = 0;
};

struct RegisterState {
    RegisterKey key;
    std::uint16_t name = 0;  // in BusState::text(): the profile's name, "" when unlisted
    std::uint16_t unit = 0;
    std::string value;  // as the profile prints it ("220.5", a label), or the raw word
    // The value's first words on the line ("0x089D 0x0000"), and how many it has in all.
    std::array<std::uint16_t, 2> raw{};
    std::uint8_t raw_words = 0;
    bool numeric = false;  // the value is a number: min, max and history hold
    bool written = false;  // BusState::write() has the last write
    Nanos last_update = kNoTime;
    Nanos last_change = kNoTime;
    std::uint32_t changes = 0;             // times the value differed from the one before
    float min = 0;
    float max = 0;
    ValueHistory history;
    // Least recently updated first: the next one forgotten at the cap (slot indexes).
    std::uint32_t older = 0;
    std::uint32_t newer = 0;
};

// Durations in a fixed-size window: the last kSize of them.
class RecentDurations {
  public:
    static constexpr std::size_t kSize = 256;
    void add(Nanos value);
    void clear() { size_ = next_ = 0; }
    [[nodiscard]] std::size_t size() const { return size_; }
    // Nearest-rank percentile of the window (as DurationCounts: a measured value).
    [[nodiscard]] std::optional<Nanos> percentile(unsigned percent) const;

  private:
    std::array<Nanos, kSize> values_{};
    std::size_t size_ = 0;
    std::size_t next_ = 0;
    mutable std::vector<Nanos> sorted_;  // scratch for percentile()
};

// Events per second over the last kSeconds seconds, on the records' clock.
class PerSecond {
  public:
    static constexpr std::size_t kSeconds = 60;
    void add(Nanos at, std::uint32_t n = 1);
    // Events within the `seconds` seconds before `now` (the current second included).
    [[nodiscard]] std::uint64_t within(Nanos now, std::size_t seconds) const;
    void clear();

  private:
    std::array<std::uint32_t, kSeconds> counts_{};
    std::int64_t last_second_ = 0;  // the second counts_ were last advanced to
    bool started_ = false;
};

// Where each register's slot is: open addressing with linear probing, each entry a key
// and its slot, so that a lookup reads this table alone. std::unordered_map's node per
// entry would take 2.5 MiB of the state's 16 at the cap, this table 1.
class SlotIndex {
  public:
    static constexpr std::uint32_t kNone = 0xFFFFFFFF;
    explicit SlotIndex(std::size_t capacity);
    [[nodiscard]] std::uint32_t find(std::uint32_t key) const;
    void insert(std::uint32_t key, std::uint32_t slot);  // the key not present
    void erase(std::uint32_t key);
    [[nodiscard]] std::size_t size() const { return size_; }

  private:
    struct Entry {
        std::uint32_t key = 0;
        std::uint32_t slot = kNone;  // kNone: empty
    };
    [[nodiscard]] std::size_t home(std::uint32_t key) const;
    std::vector<Entry> entries_;  // a power of two, twice the capacity
    std::size_t size_ = 0;
};

// The last write of a register (a write request, and its echo).
struct RegisterWrite {
    Nanos at = kNoTime;     // the write request's start
    std::uint64_t by = 0;   // that request's record number
    bool confirmed = false; // its echo came: the device took it
};

struct SlaveState {
    std::uint8_t address = 0;
    const Profile* profile = nullptr;
    Nanos first_seen = kNoTime;
    Nanos last_seen = kNoTime;
    std::uint64_t writes = 0;  // write requests
    RecentDurations turnarounds;
    PerSecond requests;
};

class BusState {
  public:
    static constexpr std::size_t kMaxRegisters = 65536;
    static constexpr std::uint8_t kFirstCustomTable = 16;

    void begin(const SessionInfo& session);
    void add(const Record& record);
    // Brings the percentiles of stats() up to date, before they are read.
    void refresh() { stats_.finish(); }
    // Forgets min/max, changes, counters and windows; values and names stay.
    void reset();

    [[nodiscard]] const SessionInfo& session() const { return stats_.session(); }
    // The counters `stats` prints, of the same records.
    [[nodiscard]] const BusStats& stats() const { return stats_; }
    // One slave's counters: its rows in stats() summed, their turnarounds left out (the
    // slave's recent ones are in SlaveState, all of them in the rows).
    [[nodiscard]] FunctionStats figures(std::uint8_t slave) const;
    // Slaves seen, by address.
    [[nodiscard]] std::vector<const SlaveState*> slaves() const;
    [[nodiscard]] const SlaveState* slave(std::uint8_t address) const;
    // A slave's registers, by table and address.
    [[nodiscard]] std::vector<const RegisterState*> registers(std::uint8_t slave) const;
    [[nodiscard]] const RegisterState* find(RegisterKey key) const;
    // Every register by slot (0 .. slot_count()-1): a slot keeps its register until the
    // register is forgotten at the cap, then holds another (its key says which).
    [[nodiscard]] std::size_t slot_count() const { return slots_.size(); }
    [[nodiscard]] const RegisterState& at_slot(std::uint32_t slot) const { return slots_[slot]; }
    // The slots of the registers the last add() set, in the record's order.
    [[nodiscard]] const std::vector<std::uint32_t>& updated_slots() const { return updated_; }
    // Its last write; nullptr if it was never written.
    [[nodiscard]] const RegisterWrite* write(const RegisterState& r) const;
    [[nodiscard]] std::size_t register_count() const { return index_.size(); }
    [[nodiscard]] std::uint64_t forgotten_registers() const { return forgotten_; }
    // A name or unit of a register.
    [[nodiscard]] std::string_view text(std::uint16_t id) const { return texts_[id]; }
    // "holding", "input", "coil", "discrete" or a device's own table.
    [[nodiscard]] std::string_view table_name(std::uint8_t table) const;

    // The bus's recent traffic, on the records' clock.
    [[nodiscard]] const PerSecond& frames() const { return frames_; }
    [[nodiscard]] const PerSecond& bytes() const { return bytes_; }
    [[nodiscard]] const PerSecond& errors() const { return errors_; }
    // Frames a second and the line's busy share (0 to 1) over the last minute, or since
    // the first frame when that is shorter (at least a second); nullopt without timing.
    struct Rates {
        double frames_per_second = 0;
        double utilisation = 0;
    };
    [[nodiscard]] std::optional<Rates> recent_rates(Nanos now) const;
    // The latest time any record carried: "now" of a replay.
    [[nodiscard]] Nanos last_time() const { return last_time_; }
    // What the last flagged records said (their notes; an exception's code), newest last.
    [[nodiscard]] std::vector<std::string> anomalies() const;
    static constexpr std::size_t kAnomalies = 8;
    // MQTT messages dropped so far (a full queue while the broker was slow or gone), as
    // the telemetry sink last read them; nullopt when nothing is published.
    [[nodiscard]] std::optional<std::uint64_t> messages_dropped() const { return dropped_; }
    void set_messages_dropped(std::optional<std::uint64_t> n) { dropped_ = n; }

  private:
    SlaveState& slave_of(std::uint8_t address, Nanos at, const Profile* profile);
    void take_values(const Record& record, bool write);
    // Returns the register's slot.
    std::uint32_t update(RegisterKey key, std::string_view name, std::string_view unit,
                std::string_view value, std::string_view raw, Nanos at, const Record& record,
                bool write);
    std::uint32_t slot_for(RegisterKey key);
    void touch(std::uint32_t slot);
    void unlink(std::uint32_t slot);
    std::uint16_t intern(std::string_view text);
    std::uint8_t table_id(const DataBlock& block);
    void note_anomaly(const Record& record);

    BusStats stats_;
    std::array<std::optional<SlaveState>, 256> slaves_;
    std::vector<RegisterState> slots_;
    // Each slot's key, packed: registers() scans these 4 bytes a slot, not the slots.
    std::vector<std::uint32_t> slot_keys_;
    std::vector<std::uint32_t> updated_;
    SlotIndex index_{kMaxRegisters};
    // Registers are seldom written: their writes apart, by slot.
    std::unordered_map<std::uint32_t, RegisterWrite> writes_;
    std::uint32_t oldest_ = 0;  // slot of the least recently updated register
    std::uint32_t newest_ = 0;
    std::uint64_t forgotten_ = 0;
    std::vector<std::string> texts_{""};
    std::unordered_map<std::string, std::uint16_t> text_ids_{{"", 0}};
    std::vector<std::string> custom_tables_;
    // The last write request per slave, awaiting its echo, and the slots it wrote.
    std::array<std::uint64_t, 256> pending_request_{};
    std::array<std::vector<std::uint32_t>, 256> pending_slots_;
    PerSecond frames_;
    PerSecond bytes_;
    PerSecond errors_;
    Nanos last_time_ = kNoTime;
    // The last kAnomalies of them, each slot's text rewritten in its own room.
    std::array<std::string, kAnomalies> anomalies_;
    std::size_t anomaly_count_ = 0;  // ever noted
    std::optional<std::uint64_t> dropped_;
    std::string scratch_;     // intern()'s
    std::string value_text_;  // a value without a profile: its word in decimal
    std::string raw_text_;    // and in hex
};

// The state shared with other threads (a dashboard's, an exporter's): the pipeline's
// thread writes it under `mutex`, and they read it under the same mutex.
struct SharedState {
    std::mutex mutex;
    BusState state;
};

}  // namespace rtuscope
