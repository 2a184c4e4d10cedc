#include "report/html_report.hpp"

#include <fmt/format.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <string_view>

#include "decode/decoder.hpp"
#include "output/fields.hpp"
#include "report/assets.hpp"
#include "stats/report.hpp"

namespace rtuscope::report {
namespace {

std::string html_escaped(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (char c : text) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

// JSON inside a <script> element: a "<" (only ever inside a string) as \u003c, so that no
// "</script>" in a file or device name can end the element.
std::string script_safe(std::string_view json) {
    std::string out;
    out.reserve(json.size());
    for (char c : json) {
        if (c == '<') {
            out += "\\u003c";
        } else {
            out += c;
        }
    }
    return out;
}

// A JSON number, or null for what is not one.
void append_number(std::string& out, double value) {
    if (!std::isfinite(value)) {
        out += "null";
        return;
    }
    fmt::format_to(std::back_inserter(out), "{:.6g}", value);
}

double seconds(Nanos t) {
    return static_cast<double>(t) / 1e9;
}

// A JSON array of one figure per bucket, `figure(i)` nullopt for an empty bucket.
template <class Figure>
void append_array(std::string& out, std::size_t count, Figure figure) {
    out += '[';
    for (std::size_t i = 0; i < count; ++i) {
        if (i > 0) out += ',';
        const std::optional<double> value = figure(i);
        if (value) {
            append_number(out, *value);
        } else {
            out += "null";
        }
    }
    out += ']';
}

std::string_view clock_of(TimeBase base) {
    switch (base) {
        case TimeBase::unix_time:
            return "local";
        case TimeBase::wall_clock:
        case TimeBase::time_of_day:
            return "utc";  // counted as UTC, shown as read
        case TimeBase::relative:
        case TimeBase::none:
            break;
    }
    return "none";
}

void append_bus(std::string& out, const Series& series, std::size_t n) {
    const auto& bus = series.bus();
    out += "\"bus\":{\"frames\":";
    append_array(out, n, [&](std::size_t i) -> std::optional<double> {
        return i < bus.size() ? bus[i].frames : 0;
    });
    out += ",\"errors\":[";
    for (std::size_t k = 0; k < kErrorKinds; ++k) {
        const ErrorKindInfo& kind = info(static_cast<ErrorKind>(k));
        fmt::format_to(std::back_inserter(out), "{}{{\"id\":\"{}\",\"label\":\"{}\",\"counts\":",
                       k > 0 ? "," : "", kind.id, kind.label);
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            return i < bus.size() ? bus[i].errors.at(k) : 0;
        });
        out += '}';
    }
    out += "]}";
}

void append_slaves(std::string& out, const Series& series, std::size_t n) {
    out += "\"slaves\":[";
    bool first = true;
    for (const auto& entry : series.slaves()) {
        const std::uint8_t slave = entry.first;
        const SlaveSeries& s = entry.second;
        const auto& b = s.buckets;
        const auto bucket = [&](std::size_t i) -> const SlaveBucket* {
            return i < b.size() ? &b[i] : nullptr;
        };
        fmt::format_to(std::back_inserter(out), "{}{{\"slave\":{},\"frames\":{},\"requests\":",
                       first ? "" : ",", slave, s.frames);
        first = false;
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            const SlaveBucket* x = bucket(i);
            return x != nullptr ? x->requests : 0;
        });
        out += ",\"answered_pct\":";
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            const SlaveBucket* x = bucket(i);
            if (x == nullptr || x->requests == 0) return std::nullopt;
            return 100.0 * x->answered / x->requests;
        });
        out += ",\"turnaround_mean_ms\":";
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            const SlaveBucket* x = bucket(i);
            if (x == nullptr || x->turnarounds == 0) return std::nullopt;
            return static_cast<double>(x->turnaround_sum_ms) / x->turnarounds;
        });
        out += ",\"turnaround_max_ms\":";
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            const SlaveBucket* x = bucket(i);
            if (x == nullptr || x->turnarounds == 0) return std::nullopt;
            return x->turnaround_max_ms;
        });
        out += ",\"cycle_mean_ms\":";
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            const SlaveBucket* x = bucket(i);
            if (x == nullptr || x->cycles == 0) return std::nullopt;
            return static_cast<double>(x->cycle_sum_ms) / x->cycles;
        });
        out += ",\"histogram\":";
        append_array(out, kHistogramBins,
                     [&](std::size_t i) -> std::optional<double> { return s.histogram.at(i); });
        out += '}';
    }
    out += ']';
}

void append_values(std::string& out, const Series& series, std::size_t n) {
    out += "\"values\":[";
    bool first = true;
    for (const ValueSeries& v : series.values()) {
        out += first ? "{" : ",{";
        first = false;
        fmt::format_to(std::back_inserter(out), "\"slave\":{},\"address\":{},", v.slave, v.address);
        out += "\"profile\":";
        append_json_string(out, v.profile);
        out += ",\"name\":";
        append_json_string(out, v.name);
        out += ",\"unit\":";
        append_json_string(out, v.unit);
        const auto bucket = [&](std::size_t i) -> const ValueBucket* {
            return i < v.buckets.size() && v.buckets[i].n != 0 ? &v.buckets[i] : nullptr;
        };
        out += ",\"min\":";
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            const ValueBucket* x = bucket(i);
            return x != nullptr ? std::optional<double>(x->min) : std::nullopt;
        });
        out += ",\"max\":";
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            const ValueBucket* x = bucket(i);
            return x != nullptr ? std::optional<double>(x->max) : std::nullopt;
        });
        out += ",\"mean\":";
        append_array(out, n, [&](std::size_t i) -> std::optional<double> {
            const ValueBucket* x = bucket(i);
            return x != nullptr ? std::optional<double>(x->sum / x->n) : std::nullopt;
        });
        fmt::format_to(std::back_inserter(out), ",\"write_count\":{},\"writes\":[", v.write_count);
        for (std::size_t i = 0; i < v.writes.size(); ++i) {
            out += i > 0 ? ",[" : "[";
            append_number(out, seconds(v.writes[i].time));
            out += ',';
            append_json_string(out, v.writes[i].value);
            out += ']';
        }
        out += "],\"max_step\":";
        append_number(out, v.steps != 0 ? v.max_step : std::nan(""));
        out += ",\"mean_step\":";
        append_number(out, v.steps != 0 ? v.step_sum / static_cast<double>(v.steps) : std::nan(""));
        out += ",\"max_step_t\":";
        append_number(out, has_time(v.max_step_time) ? seconds(v.max_step_time) : std::nan(""));
        out += '}';
    }
    fmt::format_to(std::back_inserter(out), "],\"values_left_out\":{}", series.values_left_out());
}

void append_flagged(std::string& out, const Series& series) {
    fmt::format_to(std::back_inserter(out), "\"flagged\":{{\"total\":{},\"limit\":{},\"records\":[",
                   series.flagged_count(), series.max_flagged());
    bool first = true;
    for (const FlaggedRecord& f : series.flagged()) {
        fmt::format_to(std::back_inserter(out), "{}{{\"number\":{},\"t\":", first ? "" : ",",
                       f.number);
        first = false;
        append_number(out, has_time(f.time) ? seconds(f.time) : std::nan(""));
        fmt::format_to(std::back_inserter(out), ",\"slave\":{},\"function\":{},\"kind\":\"{}\",\"notes\":[",
                       f.slave, f.function, f.kind);
        for (std::size_t i = 0; i < f.notes.size(); ++i) {
            out += i > 0 ? ",[" : "[";
            append_json_string(out, f.notes[i].first);
            out += ',';
            append_json_string(out, f.notes[i].second);
            out += ']';
        }
        out += "]}";
    }
    out += "]}";
}

// Exception names by code, from the decoder: the page names the codes as the text does.
void append_exception_names(std::string& out, const BusStats& stats) {
    out += "\"exception_names\":{";
    bool first = true;
    std::array<bool, 256> named{};
    for (const auto& [key, row] : stats.functions()) {
        for (const auto& [code, count] : row.exception_codes) {
            if (named.at(code)) continue;
            named.at(code) = true;
            const char* name = exception_name(code);
            fmt::format_to(std::back_inserter(out), "{}\"{}\":", first ? "" : ",", code);
            append_json_string(out, name != nullptr ? name : "undefined");
            first = false;
        }
    }
    out += '}';
}

std::string series_json(const BusStats& stats, const Series& series,
                        const std::vector<std::string>& remarks) {
    const std::size_t n = series.bus().size();
    std::string out = "{\"version\":\"" RTUSCOPE_VERSION "\",\"clock\":\"";
    out += clock_of(series.session().source.time_base);
    out += "\",\"t0\":";
    if (has_time(series.origin())) {
        fmt::format_to(std::back_inserter(out), "{:.3f}", seconds(series.origin()));
    } else {
        out += "null";
    }
    fmt::format_to(std::back_inserter(out), ",\"dt\":{:.6g},\"buckets\":{},\"untimed\":{},",
                   seconds(series.width()), n, series.untimed());
    append_bus(out, series, n);
    out += ',';
    append_slaves(out, series, n);
    out += ',';
    append_values(out, series, n);
    out += ',';
    append_flagged(out, series);
    out += ',';
    append_exception_names(out, stats);
    out += ",\"remarks\":[";
    for (std::size_t i = 0; i < remarks.size(); ++i) {
        if (i > 0) out += ',';
        append_json_string(out, remarks[i]);
    }
    out += "]}";
    return out;
}

// The template's {{NAME}} marks, each replaced by its part.
std::string fill(std::string_view page, const std::vector<std::pair<std::string_view, std::string_view>>& parts) {
    std::string out;
    out.reserve(page.size());
    std::size_t at = 0;
    while (at < page.size()) {
        const std::size_t open = page.find("{{", at);
        if (open == std::string_view::npos) break;
        const std::size_t close = page.find("}}", open);
        if (close == std::string_view::npos) break;
        const std::string_view name = page.substr(open + 2, close - open - 2);
        out += page.substr(at, open - at);
        bool known = false;
        for (const auto& [key, text] : parts) {
            if (key == name) {
                out += text;
                known = true;
                break;
            }
        }
        if (!known) out += page.substr(open, close + 2 - open);
        at = close + 2;
    }
    out += page.substr(at);
    return out;
}

}  // namespace

std::string render_html(const BusStats& stats, const Series& series,
                        const std::vector<std::string>& remarks) {
    const std::string stats_jsonl = script_safe(render_stats(stats, StatsFormat::jsonl));
    const std::string data = script_safe(series_json(stats, series, remarks));
    const std::string& name = series.session().source.name;
    const std::string title = html_escaped(fmt::format("rtuscope report: {}", name.empty() ? "bus" : name));
    const std::string license = html_escaped(assets::uplot_license());
    return fill(assets::page_html(), {{"TITLE", title},
                                      {"UPLOT_CSS", assets::uplot_css()},
                                      {"UPLOT_JS", assets::uplot_js()},
                                      {"UPLOT_LICENSE", license},
                                      {"PAGE_JS", assets::page_js()},
                                      {"STATS_JSONL", stats_jsonl},
                                      {"SERIES_JSON", data}});
}

Status write_page(const std::string& path, const std::string& html) {
    const std::string temporary = path + ".tmp";
    std::FILE* file = std::fopen(temporary.c_str(), "wb");
    if (file == nullptr) return Error{fmt::format("cannot write the report: {}", std::strerror(errno)), path};
    const bool written = std::fwrite(html.data(), 1, html.size(), file) == html.size();
    const int write_errno = errno;
    if (std::fclose(file) != 0 || !written) {
        std::remove(temporary.c_str());
        return Error{fmt::format("cannot write the report: {}",
                                 std::strerror(written ? errno : write_errno)),
                     path};
    }
    if (std::rename(temporary.c_str(), path.c_str()) != 0) {
        const int rename_errno = errno;
        std::remove(temporary.c_str());
        return Error{fmt::format("cannot write the report: {}", std::strerror(rename_errno)), path};
    }
    return ok_status();
}

ReportSink::ReportSink(std::string path, std::size_t max_flagged, std::atomic<bool>* write_now)
    : path_(std::move(path)), write_now_(write_now), series_(max_flagged) {}

void ReportSink::begin(const SessionInfo& session) {
    stats_.begin(session);
    series_.begin(session);
}

void ReportSink::record(const Record& record) {
    stats_.add(record);
    series_.add(record);
    write_if_asked();
}

void ReportSink::idle(Nanos /*now*/) {
    write_if_asked();
}

void ReportSink::write_if_asked() {
    // A load first: the exchange, a write, is paid only when the flag is set.
    if (write_now_ == nullptr || !write_now_->load(std::memory_order_relaxed) ||
        !write_now_->exchange(false)) {
        return;
    }
    // The run goes on: the page is of a finished copy of the figures so far.
    BusStats so_far = stats_;
    so_far.finish();
    write(so_far, {});
}

void ReportSink::end(const Totals& /*totals*/, const std::vector<std::string>& remarks) {
    stats_.finish();
    write(stats_, remarks);
}

void ReportSink::write(const BusStats& finished, const std::vector<std::string>& remarks) {
    Status written = write_page(path_, render_html(finished, series_, remarks));
    if (!written && status_) status_ = std::move(written);
}

Result<std::unique_ptr<ReportSink>> make_report_sink(const std::string& path,
                                                     std::size_t max_flagged,
                                                     std::atomic<bool>* write_now) {
    // Said before the run rather than after it: a directory that does not exist, a file
    // that cannot be written.
    // The temporary file is tried, so that an earlier page stays until the new one is made.
    const std::string temporary = path + ".tmp";
    std::FILE* file = std::fopen(temporary.c_str(), "wb");
    if (file == nullptr) {
        return Error{fmt::format("cannot write the report: {}", std::strerror(errno)), path};
    }
    std::fclose(file);
    std::remove(temporary.c_str());
    return std::make_unique<ReportSink>(path, max_flagged, write_now);
}

}  // namespace rtuscope::report
