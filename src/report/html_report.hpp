// `rtuscope report`: one self-contained HTML page of the bus (docs/report.md). The page
// holds uPlot (third_party/uplot, inlined at build time), the page's own script, and the
// data as JSON: the statistics exactly as `rtuscope stats --jsonl` prints them
// (stats/report.hpp) and the series over time (series.hpp). It needs no network.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "pipeline.hpp"
#include "report/series.hpp"
#include "stats/bus_stats.hpp"
#include "util/result.hpp"

namespace rtuscope::report {

inline constexpr std::size_t kDefaultFlagged = 100;

// The page: finished `stats`, `series` of the same records.
std::string render_html(const BusStats& stats, const Series& series,
                        const std::vector<std::string>& remarks);

// Writes `html` to `path` through a temporary file beside it, renamed over it: a
// browser or a mail client never finds half a page.
Status write_page(const std::string& path, const std::string& html);

// A RecordSink that collects the page's figures and writes it to `path` at the end, and
// whenever `write_now` (a flag a signal sets) is found set, clearing it.
class ReportSink final : public RecordSink {
  public:
    ReportSink(std::string path, std::size_t max_flagged, std::atomic<bool>* write_now);

    void begin(const SessionInfo& session) override;
    void record(const Record& record) override;
    void idle(Nanos now) override;
    void end(const Totals& totals, const std::vector<std::string>& remarks) override;

    // The first page that could not be written, if any.
    [[nodiscard]] const Status& status() const { return status_; }
    [[nodiscard]] const std::string& path() const { return path_; }

  private:
    void write_if_asked();
    void write(const BusStats& finished, const std::vector<std::string>& remarks);

    std::string path_;
    std::atomic<bool>* write_now_;
    BusStats stats_;
    Series series_;
    Status status_ = ok_status();
};

// Checks that `path` can be written (creating it) before a run starts.
Result<std::unique_ptr<ReportSink>> make_report_sink(const std::string& path,
                                                     std::size_t max_flagged,
                                                     std::atomic<bool>* write_now);

}  // namespace rtuscope::report
