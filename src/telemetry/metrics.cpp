#include "telemetry/metrics.hpp"

#include <CivetServer.h>
#include <civetweb.h>
#include <fmt/format.h>
#include <netdb.h>
#include <prometheus/collectable.h>
#include <prometheus/exposer.h>
#include <prometheus/metric_family.h>
#include <prometheus/text_serializer.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

namespace rtuscope {
namespace {

using prometheus::ClientMetric;
using prometheus::MetricFamily;
using prometheus::MetricType;
using Labels = std::vector<ClientMetric::Label>;

// Upper bounds of the turnaround buckets, in seconds (Prometheus' base unit): from a fast
// device's millisecond to the second past which most masters give up.
constexpr std::array<double, 10> kTurnaroundBounds = {0.001, 0.002, 0.005, 0.01, 0.02,
                                                      0.05,  0.1,   0.2,   0.5,  1.0};

struct TurnaroundHistogram {
    std::array<std::uint64_t, kTurnaroundBounds.size() + 1> counts{};  // per bucket; last +Inf
    double sum = 0;  // seconds
    std::uint64_t count = 0;

    void add(Nanos latency) {
        const double seconds = static_cast<double>(latency) / 1e9;
        const auto bucket = static_cast<std::size_t>(
            std::lower_bound(kTurnaroundBounds.begin(), kTurnaroundBounds.end(), seconds) -
            kTurnaroundBounds.begin());
        ++counts[bucket];
        sum += seconds;
        ++count;
    }
};

// The answers whose turnaround `stats` counts: to a waiting request, whatever their kind.
bool has_turnaround(const Record& record) {
    const bool answer = record.kind == Kind::response || record.kind == Kind::exception ||
                        (record.kind == Kind::invalid && record.request_number != 0);
    return answer && has_time(record.latency) && !record.answers_no_request() &&
           !record.notes.has(note_id::cut_by_stop) && !record.notes.has(note_id::cut_by_snaplen);
}

std::optional<double> number_of(std::string_view text) {
    double v = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
    return v;
}

MetricFamily family(std::string name, std::string help, MetricType type) {
    MetricFamily f;
    f.name = std::move(name);
    f.help = std::move(help);
    f.type = type;
    return f;
}

// What a scrape reads. The state is the pipeline's; the histograms are this collector's
// own, written by the exporter on the pipeline's thread. Both under the state's mutex.
class MetricsCollector final : public prometheus::Collectable {
  public:
    MetricsCollector(std::shared_ptr<SharedState> shared, std::string bus, std::size_t max_series)
        : shared_(std::move(shared)), bus_(std::move(bus)), max_series_(max_series) {}

    std::vector<MetricFamily> Collect() const override {
        ++scrapes_;
        return snapshot();
    }
    [[nodiscard]] std::vector<MetricFamily> snapshot() const {
        const std::lock_guard lock(shared_->mutex);
        return families(shared_->state);
    }

    // Called with the state's mutex held.
    void record(const BusState& state, const Record& record) {
        if (has_turnaround(record)) turnarounds_[record.frame.slave()].add(record.latency);
        now_ = std::max(now_, state.last_time());
    }
    void tick(Nanos now) { now_ = std::max(now_, now); }

    [[nodiscard]] std::uint64_t scrapes() const { return scrapes_; }

  private:
    [[nodiscard]] std::vector<MetricFamily> families(const BusState& state) const;
    void add_counts(std::vector<MetricFamily>& out, const BusState& state) const;
    void add_turnarounds(std::vector<MetricFamily>& out) const;
    void add_registers(std::vector<MetricFamily>& out, const BusState& state) const;

    [[nodiscard]] Labels labels(std::initializer_list<ClientMetric::Label> more) const {
        Labels l{{"bus", bus_}};
        l.insert(l.end(), more);
        return l;
    }
    void add(MetricFamily& f, double value, std::initializer_list<ClientMetric::Label> more) const {
        ClientMetric& m = f.metric.emplace_back();
        m.label = labels(more);
        if (f.type == MetricType::Counter) {
            m.counter.value = value;
        } else {
            m.gauge.value = value;
        }
    }

    std::shared_ptr<SharedState> shared_;
    std::string bus_;
    std::size_t max_series_;
    std::map<std::uint8_t, TurnaroundHistogram> turnarounds_;
    Nanos now_ = kNoTime;
    mutable std::atomic<std::uint64_t> scrapes_{0};
};

std::vector<MetricFamily> MetricsCollector::families(const BusState& state) const {
    std::vector<MetricFamily> out;
    add_counts(out, state);
    add_turnarounds(out);
    add_registers(out, state);
    return out;
}

void MetricsCollector::add_counts(std::vector<MetricFamily>& out, const BusState& state) const {
    const BusStats& stats = state.stats();
    const BusFigures& bus = stats.bus();

    // Per slave and function: the columns of `stats`' rows.
    MetricFamily frames = family(
        "rtuscope_frames_total",
        "Frames per slave, function and kind, as `rtuscope stats` counts them: requests "
        "awaiting an answer, answers, exceptions, broken answers, broadcasts, unsolicited "
        "answers.",
        MetricType::Counter);
    for (const auto& [key, row] : stats.functions()) {
        const std::string slave = std::to_string(key.first);
        const std::string function = std::to_string(key.second);
        const std::array<std::pair<const char*, std::uint64_t>, 6> kinds = {{
            {"request", row.requests},
            {"answer", row.answers},
            {"exception", row.exceptions},
            {"broken", row.broken},
            {"broadcast", row.broadcasts},
            {"unsolicited", row.unsolicited},
        }};
        for (const auto& [kind, n] : kinds) {
            add(frames, static_cast<double>(n),
                {{"slave", slave}, {"function", function}, {"kind", kind}});
        }
    }

    // Per slave: its rows summed.
    MetricFamily requests = family("rtuscope_requests_total",
                                   "Requests awaiting an answer, per slave.", MetricType::Counter);
    MetricFamily answers =
        family("rtuscope_answers_total", "Normal answers to a request, per slave.",
               MetricType::Counter);
    MetricFamily no_answers = family("rtuscope_no_answers_total",
                                     "Requests that got no answer in time, per slave.",
                                     MetricType::Counter);
    MetricFamily crc_errors = family("rtuscope_crc_errors_total",
                                     "Frames with a bad or swapped CRC, per slave address.",
                                     MetricType::Counter);
    MetricFamily exceptions = family("rtuscope_exceptions_total",
                                     "Exception answers per slave and exception code.",
                                     MetricType::Counter);
    std::optional<std::uint8_t> last;
    for (const auto& [key, row] : stats.functions()) {
        if (last == key.first) continue;
        last = key.first;
        const FunctionStats f = state.figures(key.first);
        const std::string slave = std::to_string(key.first);
        add(requests, static_cast<double>(f.requests), {{"slave", slave}});
        add(answers, static_cast<double>(f.answers), {{"slave", slave}});
        add(no_answers, static_cast<double>(f.no_answer), {{"slave", slave}});
        add(crc_errors, static_cast<double>(f.crc_errors), {{"slave", slave}});
        for (const auto& [code, n] : f.exception_codes) {
            add(exceptions, static_cast<double>(n), {{"slave", slave}, {"code", std::to_string(code)}});
        }
    }

    MetricFamily bytes = family("rtuscope_bytes_total",
                                "Bytes on the line, noise included.", MetricType::Counter);
    add(bytes, static_cast<double>(bus.bytes), {});
    MetricFamily noise = family("rtuscope_noise_bytes_total",
                                "Bytes on the line that belong to no frame.", MetricType::Counter);
    add(noise, static_cast<double>(bus.noise_bytes), {});
    MetricFamily utilisation =
        family("rtuscope_bus_utilisation_ratio",
               "Share of the last minute the line carried a character (0 to 1), at the "
               "line's settings; absent without timing.",
               MetricType::Gauge);
    if (const auto rates = state.recent_rates(std::max(now_, state.last_time()))) {
        add(utilisation, rates->utilisation, {});
    }

    MetricFamily dropped = family("rtuscope_mqtt_dropped_messages_total",
                                  "MQTT messages dropped (a full queue while the broker was slow "
                                  "or gone); absent without --mqtt.",
                                  MetricType::Counter);
    if (const auto n = state.messages_dropped()) add(dropped, static_cast<double>(*n), {});

    for (MetricFamily* f : {&frames, &requests, &answers, &no_answers, &crc_errors, &exceptions,
                            &bytes, &noise, &utilisation, &dropped}) {
        out.push_back(std::move(*f));
    }
}

void MetricsCollector::add_turnarounds(std::vector<MetricFamily>& out) const {
    MetricFamily f = family("rtuscope_turnaround_seconds",
                            "End of request to start of answer, per slave.",
                            MetricType::Histogram);
    for (const auto& [address, h] : turnarounds_) {
        ClientMetric& m = f.metric.emplace_back();
        m.label = labels({{"slave", std::to_string(address)}});
        m.histogram.sample_count = h.count;
        m.histogram.sample_sum = h.sum;
        std::uint64_t cumulative = 0;
        for (std::size_t i = 0; i < h.counts.size(); ++i) {
            cumulative += h.counts[i];
            const double bound = i < kTurnaroundBounds.size()
                                     ? kTurnaroundBounds[i]
                                     : std::numeric_limits<double>::infinity();
            m.histogram.bucket.push_back({cumulative, bound});
        }
    }
    out.push_back(std::move(f));
}

void MetricsCollector::add_registers(std::vector<MetricFamily>& out,
                                     const BusState& state) const {
    MetricFamily f = family("rtuscope_register",
                            "The last value of each numeric register, in its unit.",
                            MetricType::Gauge);
    std::uint64_t dropped = 0;
    for (const SlaveState* s : state.slaves()) {
        const std::string slave = std::to_string(s->address);
        for (const RegisterState* r : state.registers(s->address)) {
            if (!r->numeric) continue;
            const std::optional<double> value = number_of(r->value);
            if (!value) continue;
            if (f.metric.size() >= max_series_) {
                ++dropped;
                continue;
            }
            add(f, *value,
                {{"slave", slave},
                 {"table", std::string(state.table_name(r->key.table))},
                 {"address", fmt::format("0x{:04X}", r->key.address)},
                 {"name", std::string(state.text(r->name))},
                 {"unit", std::string(state.text(r->unit))}});
        }
    }
    out.push_back(std::move(f));
    MetricFamily d = family("rtuscope_register_series_dropped",
                            "Numeric registers left out of rtuscope_register (over --metrics' "
                            "series limit).",
                            MetricType::Gauge);
    add(d, static_cast<double>(dropped), {});
    out.push_back(std::move(d));
}

// Opens a connection to "ADDR:PORT" and closes it; "0.0.0.0" is this host.
void connect_and_close(const std::string& endpoint) {
    const auto colon = endpoint.rfind(':');
    std::string host = endpoint.substr(0, colon);
    if (host == "0.0.0.0") host = "127.0.0.1";
    const std::string port = endpoint.substr(colon + 1);
    addrinfo hints{};
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* found = nullptr;
    if (::getaddrinfo(host.c_str(), port.c_str(), &hints, &found) != 0) return;
    if (const int fd = ::socket(found->ai_family, found->ai_socktype, found->ai_protocol); fd >= 0) {
        // Whether it connects does not matter: the attempt is the point.
        (void)::connect(fd, found->ai_addr, found->ai_addrlen);
        ::close(fd);
    }
    ::freeaddrinfo(found);
}

// civetweb says why it cannot listen through its log callback, on the thread that starts
// it: the first message is the cause.
thread_local std::string* start_messages = nullptr;
int take_start_message(const mg_connection* /*connection*/, const char* message) {
    if (start_messages == nullptr) return 0;  // a running server's: civetweb's own handling
    if (start_messages->empty()) *start_messages = message;
    return 1;
}

// Why `listen` could not be bound, from civetweb's message.
std::string bind_failure(const std::string& listen, std::string_view message) {
    // "cannot bind to 127.0.0.1:80: 98 (Address already in use)"
    const std::string prefix = "cannot bind to " + listen + ": ";
    if (message.substr(0, prefix.size()) == prefix) {
        message.remove_prefix(prefix.size());
        const auto open = message.find(" (");
        if (open != std::string_view::npos && message.back() == ')') {
            return std::string(message.substr(open + 2, message.size() - open - 3));
        }
        return std::string(message);
    }
    if (message.find("invalid port spec") != std::string_view::npos) {
        return "not an IPv4 address or a host name known here";
    }
    return message.empty() ? std::string("the server did not start") : std::string(message);
}

class MetricsExporter final : public Exporter {
  public:
    MetricsExporter(std::shared_ptr<MetricsCollector> collector,
                    std::unique_ptr<prometheus::Exposer> exposer, std::string endpoint)
        : collector_(std::move(collector)),
          exposer_(std::move(exposer)),
          endpoint_(std::move(endpoint)) {
        exposer_->RegisterCollectable(collector_);
    }
    ~MetricsExporter() override {
        // The server's threads stop before the collector goes. Its listening thread sees
        // the stop only when its poll of the socket returns, after up to 2 s: a connection
        // ends the poll at once.
        std::atomic<bool> stopped{false};
        std::thread waker([&] {
            while (!stopped) {
                connect_and_close(endpoint_);
                std::this_thread::sleep_for(std::chrono::milliseconds(5));
            }
        });
        exposer_.reset();
        stopped = true;
        waker.join();
    }
    MetricsExporter(const MetricsExporter&) = delete;
    MetricsExporter& operator=(const MetricsExporter&) = delete;
    MetricsExporter(MetricsExporter&&) = delete;
    MetricsExporter& operator=(MetricsExporter&&) = delete;

    void record(const BusState& state, const Record& record) override {
        collector_->record(state, record);
    }
    void tick(const BusState& /*state*/, Nanos now) override { collector_->tick(now); }
    [[nodiscard]] std::string summary() const override {
        const std::uint64_t n = collector_->scrapes();
        return fmt::format("metrics: {} {} of http://{}/metrics", n, n == 1 ? "scrape" : "scrapes",
                           endpoint_);
    }

    [[nodiscard]] const std::string& endpoint() const { return endpoint_; }
    [[nodiscard]] const MetricsCollector& collector() const { return *collector_; }

  private:
    std::shared_ptr<MetricsCollector> collector_;
    std::unique_ptr<prometheus::Exposer> exposer_;
    std::string endpoint_;
};

// "127.0.0.1:0" with the port the server got.
std::string with_port(const std::string& listen, int port) {
    return listen.substr(0, listen.rfind(':') + 1) + std::to_string(port);
}

}  // namespace

Result<std::string> parse_listen_address(std::string_view text) {
    const auto bad = [&](std::string_view why) {
        return Error(fmt::format("metrics address \"{}\": {}", text, why));
    };
    std::string_view host = "127.0.0.1";
    std::string_view port = text;
    if (const auto colon = text.rfind(':'); colon != std::string_view::npos) {
        port = text.substr(colon + 1);
        if (colon > 0) host = text.substr(0, colon);
        const bool bracketed = host.size() >= 2 && host.front() == '[' && host.back() == ']';
        if (!bracketed && host.find_first_of(":[]") != std::string_view::npos) {
            return bad("an IPv6 address goes in brackets, as [::1]:9464");
        }
        if (bracketed && host.size() == 2) return bad("the address in brackets is empty");
    }
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
    if (port.empty() || ec != std::errc{} || end != port.data() + port.size() || value > 65535) {
        return bad("the port must be a number from 0 to 65535");
    }
    return fmt::format("{}:{}", host, value);
}

Result<std::unique_ptr<Exporter>> start_metrics(const MetricsOptions& options,
                                                std::shared_ptr<SharedState> shared) {
    auto listen = parse_listen_address(options.listen);
    if (!listen) return listen.error();
    constexpr unsigned kIpv6Feature = 8;
    if (listen->front() == '[' && mg_check_feature(kIpv6Feature) == 0) {
        return Error(fmt::format("cannot listen on {}: the civetweb library here has no IPv6",
                                 *listen));
    }
    std::unique_ptr<prometheus::Exposer> exposer;
    std::string message;
    start_messages = &message;
    try {
        CivetCallbacks callbacks;
        callbacks.log_message = take_start_message;
        // One thread serves a scrape at a time: Prometheus scrapes one target serially,
        // and every scrape waits on the state's mutex anyway.
        exposer = std::make_unique<prometheus::Exposer>(*listen, 1, &callbacks);
    } catch (const std::exception& e) {
        start_messages = nullptr;
        return Error(fmt::format("cannot listen on {}: {}", *listen, bind_failure(*listen, message)));
    }
    start_messages = nullptr;
    const std::vector<int> ports = exposer->GetListeningPorts();
    if (ports.empty()) return Error(fmt::format("cannot listen on {}", *listen));
    auto collector =
        std::make_shared<MetricsCollector>(std::move(shared), options.bus, options.max_series);
    return std::unique_ptr<Exporter>(std::make_unique<MetricsExporter>(
        std::move(collector), std::move(exposer), with_port(*listen, ports.front())));
}

std::string metrics_endpoint(const Exporter& metrics) {
    const auto* m = dynamic_cast<const MetricsExporter*>(&metrics);
    return m != nullptr ? m->endpoint() : std::string();
}

std::string metrics_text(const Exporter& metrics) {
    const auto* m = dynamic_cast<const MetricsExporter*>(&metrics);
    if (m == nullptr) return {};
    return prometheus::TextSerializer().Serialize(m->collector().snapshot());
}

}  // namespace rtuscope
