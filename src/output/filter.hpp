// Record filters (--slave, --function, --kind, --from, --to) and sink combinators: a
// filter in front of a sink, and a tee that feeds several sinks (text and --pcap, or the
// output and sniff's closing statistics).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "pipeline.hpp"
#include "util/result.hpp"

namespace rtuscope {

struct RecordFilter {
    using Ranges = std::vector<std::pair<unsigned, unsigned>>;
    Ranges slaves;                   // empty: any
    Ranges functions;                // function & 0x7F, so exceptions match their function
    std::vector<std::string> kinds;  // request, response, ... noise, or "flagged"
    std::optional<Nanos> from;       // frame start, in the input's timebase
    std::optional<Nanos> to;
    bool from_relative = false;  // "+S": seconds after the first record
    bool to_relative = false;

    [[nodiscard]] bool empty() const;
    // `first` is the start of the first timed record of the input.
    [[nodiscard]] bool matches(const Record& record, Nanos first) const;
};

// "1,3,10-20,0x10" (decimal or 0x hex, inclusive ranges) up to `max`.
Result<RecordFilter::Ranges> parse_ranges(std::string_view text, unsigned max);
// "request,exception,flagged": the CSV kinds, and "flagged" for any record with a note.
Result<std::vector<std::string>> parse_kinds(std::string_view text);
// "1763798400.5" (the CSV time column's seconds) or "+2.5" (after the first record).
Result<std::pair<Nanos, bool>> parse_time_bound(std::string_view text);

std::unique_ptr<RecordSink> make_filter_sink(RecordFilter filter,
                                             std::unique_ptr<RecordSink> inner);
std::unique_ptr<RecordSink> make_tee_sink(std::vector<std::unique_ptr<RecordSink>> sinks);

}  // namespace rtuscope
