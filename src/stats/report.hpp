// The bus statistics as people and programs read them: an aligned text table, CSV or JSON
// lines (docs/formats.md), written in pieces as they are made; and the sink that counts a
// run's records and prints them at its end (`rtuscope stats`, the closing summary of
// `sniff` and `demo`).
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "pipeline.hpp"
#include "stats/bus_stats.hpp"

namespace rtuscope {

enum class StatsFormat : std::uint8_t { text, csv, jsonl };

// The statistics as `format` prints them, handed to `send` in pieces of about 64 KiB as
// they are made (a table of every slave and function is megabytes: it is never held
// whole); `remarks` are the source's (text only).
// The text lists the `top` busiest rows, exceptions and polls (0: all of them) and counts
// the rest; CSV and JSON Lines always hold every row.
inline constexpr std::size_t kStatsTop = 20;
void write_stats(const BusStats& stats, StatsFormat format, const std::vector<std::string>& remarks,
                 const std::function<void(std::string_view)>& send, std::size_t top = kStatsTop);
// The same, whole, as one string.
std::string render_stats(const BusStats& stats, StatsFormat format,
                         const std::vector<std::string>& remarks = {},
                         std::size_t top = kStatsTop);

// A RecordSink that counts instead of printing records; end() prints the statistics.
std::unique_ptr<RecordSink> make_stats_sink(std::FILE* out, StatsFormat format,
                                            std::size_t top = kStatsTop);

}  // namespace rtuscope
