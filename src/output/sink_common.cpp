// What more than one sink writes alike: a record's summary, its flags and notes.
#include <fmt/format.h>

#include "output/sinks.hpp"

namespace rtuscope {

void append_summary(std::string& out, const Record& record) {
    if (record.kind == Kind::noise) {
        fmt::format_to(std::back_inserter(out), "noise, {} byte{}", record.frame.bytes.size(),
                       record.frame.bytes.size() == 1 ? "" : "s");
        return;
    }
    const DecodedPdu& d = record.decoded;
    out += d.function_name;
    if (!d.summary.empty()) {
        out += ' ';
        out += d.summary;
    }
}

void append_unlisted_registers_text(std::string& out, std::size_t count) {
    fmt::format_to(std::back_inserter(out), "{} register{} not in the profile", count,
                   count == 1 ? "" : "s");
}

}  // namespace rtuscope
