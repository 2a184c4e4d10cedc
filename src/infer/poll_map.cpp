#include "infer/poll_map.hpp"

#include <algorithm>
#include <array>
#include <span>

namespace rtuscope::infer {
namespace {

std::uint16_t word_at(std::span<const std::uint8_t> bytes, std::size_t at) {
    return static_cast<std::uint16_t>((bytes[at] << 8) | bytes[at + 1]);
}

struct FunctionTable {
    std::uint8_t code;
    Table table;
};
constexpr std::array<FunctionTable, 8> kFunctionTables{{{0x01, Table::coil},
                                                         {0x02, Table::discrete},
                                                         {0x03, Table::holding},
                                                         {0x04, Table::input},
                                                         {0x05, Table::coil},
                                                         {0x06, Table::holding},
                                                         {0x0F, Table::coil},
                                                         {0x10, Table::holding}}};

const FunctionTable* function_table(std::uint8_t code) {
    for (const FunctionTable& f : kFunctionTables) {
        if (f.code == code) return &f;
    }
    return nullptr;
}

bool is_read(std::uint8_t code) {
    return code >= 0x01 && code <= 0x04;
}

template <typename T>
void add_distinct(std::vector<T>& list, T value, std::size_t most) {
    if (list.size() < most && std::find(list.begin(), list.end(), value) == list.end()) {
        list.push_back(value);
    }
}

}  // namespace

const char* table_name(Table table) {
    switch (table) {
        case Table::coil:
            return "coil";
        case Table::discrete:
            return "discrete";
        case Table::holding:
            return "holding";
        case Table::input:
            return "input";
    }
    return "";
}

bool is_bit_table(Table table) {
    return table == Table::coil || table == Table::discrete;
}

void PollMapBuilder::add(const Record& record) {
    const bool answer = record.kind == Kind::response && !record.request.empty();
    const bool broadcast = record.kind == Kind::broadcast;
    if (record.kind == Kind::exception) {
        ++slaves_[record.frame.slave()].exceptions;
        slaves_[record.frame.slave()].slave = record.frame.slave();
        return;
    }
    if (!answer && !broadcast) return;
    const std::span<const std::uint8_t> request =
        answer ? pdu_of(record.request, record.frame.transport) : record.frame.pdu();
    if (request.empty() || function_table(request[0]) == nullptr) return;
    const std::uint8_t slave = record.frame.slave();
    if (answer && (record.frame.pdu().empty() || record.frame.pdu()[0] != request[0])) return;
    SlaveTraffic& traffic = slaves_[slave];
    traffic.slave = slave;
    if (is_read(request[0])) {
        if (answer) add_read(traffic, record, request, record.frame.pdu());
    } else {
        add_write(traffic, request);
    }
}

void PollMapBuilder::add_read(SlaveTraffic& slave, const Record& record,
                              std::span<const std::uint8_t> request,
                              std::span<const std::uint8_t> answer) {
    if (request.size() < 5 || answer.size() < 2) return;
    const std::uint8_t code = request[0];
    const Table table = function_table(code)->table;
    const std::uint16_t start = word_at(request, 1);
    const std::uint16_t count = word_at(request, 3);
    const std::size_t byte_count = answer[1];
    if (count == 0 || answer.size() < 2 + byte_count) return;
    // The values the answer carries: all the bits asked for, or as many registers as it
    // holds (a device may answer fewer than asked; never more).
    std::size_t values = 0;
    if (is_bit_table(table)) {
        if (byte_count != (count + 7U) / 8U) return;
        values = count;
    } else {
        if (byte_count % 2 != 0 || byte_count / 2 > count || byte_count == 0) return;
        values = byte_count / 2;
    }
    if (start + values > 0x10000) return;
    ++slave.answered_reads;
    auto block = std::find_if(slave.blocks.begin(), slave.blocks.end(), [&](const ReadBlock& b) {
        return b.key() == std::tuple(table, code, start, count);
    });
    if (block == slave.blocks.end()) {
        block = slave.blocks.insert(slave.blocks.end(), ReadBlock{table, code, start, count, 0, {}});
    }
    ++block->polls;
    if (block->times.size() < kMaxSamples && has_time(record.frame.start)) {
        block->times.push_back(record.frame.start);
    }
    const std::span<const std::uint8_t> data = answer.subspan(2, byte_count);
    for (std::size_t i = 0; i < values; ++i) {
        const std::uint16_t value = is_bit_table(table)
                                        ? static_cast<std::uint16_t>((data[i / 8] >> (i % 8)) & 1U)
                                        : word_at(data, 2 * i);
        std::vector<Sample>& samples =
            slave.reads[RegisterKey{table, static_cast<std::uint16_t>(start + i)}];
        if (samples.size() < kMaxSamples) {
            samples.push_back(Sample{record.number, record.frame.start, value});
        }
    }
}

void PollMapBuilder::add_write(SlaveTraffic& slave, std::span<const std::uint8_t> request) {
    const std::uint8_t code = request[0];
    const Table table = function_table(code)->table;
    const auto written = [&](std::uint32_t address, std::uint16_t value) {
        if (address > 0xFFFF) return;
        WriteSeen& seen = slave.writes[RegisterKey{table, static_cast<std::uint16_t>(address)}];
        ++seen.count;
        add_distinct(seen.functions, code, kFunctionTables.size());
        add_distinct(seen.values, value, kMaxWrittenValues);
    };
    if (code == 0x05 || code == 0x06) {
        if (request.size() < 5) return;
        const std::uint16_t value = word_at(request, 3);
        if (code == 0x05 && value != 0xFF00 && value != 0x0000) return;
        written(word_at(request, 1), code == 0x05 ? static_cast<std::uint16_t>(value != 0) : value);
        return;
    }
    // FC0F, FC10: start, quantity, byte count, data.
    if (request.size() < 6) return;
    const std::uint16_t start = word_at(request, 1);
    const std::uint16_t count = word_at(request, 3);
    const std::size_t byte_count = request[5];
    if (request.size() < 6 + byte_count || count == 0) return;
    const std::span<const std::uint8_t> data = request.subspan(6, byte_count);
    if (code == 0x0F) {
        if (byte_count != (count + 7U) / 8U) return;
        for (std::size_t i = 0; i < count; ++i) {
            written(static_cast<std::uint32_t>(start + i), static_cast<std::uint16_t>((data[i / 8] >> (i % 8)) & 1U));
        }
        return;
    }
    if (byte_count != std::size_t{2} * count) return;
    for (std::size_t i = 0; i < count; ++i) written(static_cast<std::uint32_t>(start + i), word_at(data, 2 * i));
}

Nanos median_period(const std::vector<Nanos>& times) {
    if (times.size() < 2) return kNoTime;
    std::vector<Nanos> periods;
    periods.reserve(times.size() - 1);
    for (std::size_t i = 1; i < times.size(); ++i) periods.push_back(times[i] - times[i - 1]);
    std::nth_element(periods.begin(), periods.begin() + static_cast<std::ptrdiff_t>(periods.size() / 2),
                     periods.end());
    return periods[periods.size() / 2];
}

}  // namespace rtuscope::infer
