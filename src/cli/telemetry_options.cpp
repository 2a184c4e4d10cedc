#include "telemetry_options.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "errors.hpp"
#include "output/filter.hpp"
#include "stop_signals.hpp"
#include "telemetry/metrics.hpp"
#include "telemetry/mqtt.hpp"

namespace rtuscope::cli {

void add_telemetry_options(CLI::App& cmd, TelemetryArgs& args, bool with_metrics) {
    const std::string group = "Telemetry";
    cmd.add_option("--bus-name", args.bus_name,
                   "The bus's name in topics and labels (default: the port's or file's base "
                   "name, 'demo' for the demo)")
        ->group(group);
    cmd.add_option("--mqtt", args.mqtt,
                   "Publish values, health and availability to an MQTT broker: "
                   "mqtt://host[:port][/prefix] or mqtts://... (credentials from "
                   "RTUSCOPE_MQTT_USERNAME and RTUSCOPE_MQTT_PASSWORD)")
        ->type_name("URL")
        ->group(group);
    cmd.add_option("--mqtt-ca", args.mqtt_ca, "mqtts: the CA certificate to trust")
        ->type_name("FILE")
        ->group(group);
    cmd.add_option("--mqtt-cert", args.mqtt_cert, "mqtts: a client certificate")
        ->type_name("FILE")
        ->group(group);
    cmd.add_option("--mqtt-key", args.mqtt_key, "mqtts: the client certificate's key")
        ->type_name("FILE")
        ->group(group);
    cmd.add_option("--mqtt-password-file", args.mqtt_password_file,
                   "Read the broker's password from FILE (its first line)")
        ->type_name("FILE")
        ->group(group);
    cmd.add_option("--mqtt-interval", args.mqtt_interval_s,
                   "Republish unchanged values and health every S seconds (default 60)")
        ->type_name("S")
        ->check(CLI::PositiveNumber)
        ->group(group);
    cmd.add_flag("--ha-discovery", args.ha_discovery,
                 "Announce every slave and register to Home Assistant (MQTT discovery)")
        ->group(group);
    cmd.add_option("--ha-prefix", args.ha_prefix,
                   "Home Assistant's discovery prefix (default homeassistant)")
        ->group(group);
    cmd.add_flag("--mqtt-required", args.mqtt_required,
                 "Stop with exit status 1 when the broker refuses the connection, instead of "
                 "going on without MQTT")
        ->group(group);
    if (!with_metrics) return;
    cmd.add_option("--metrics", args.metrics,
                   "Serve Prometheus metrics at http://ADDR:PORT/metrics (PORT alone: on "
                   "127.0.0.1)")
        ->type_name("ADDR:PORT")
        ->group(group);
    cmd.add_option("--metrics-max-series", args.metrics_max_series,
                   "At most N register gauges; the others are counted (default 10000)")
        ->type_name("N")
        ->group(group);
}

namespace {

// The first line of the file, without its line end.
Result<std::string> read_password(const std::string& path) {
    std::ifstream in(path);
    if (!in) return Error{"cannot read the password file", path};
    std::string line;
    std::getline(in, line);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return line;
}

}  // namespace

std::optional<Telemetry> attach_telemetry(const TelemetryArgs& args, std::string_view input,
                                          Decoding& decoding, int& exit_code, bool always) {
    const bool wanted = !args.mqtt.empty() || !args.metrics.empty();
    Telemetry telemetry;
    telemetry.shared = std::make_shared<SharedState>();
    if (!wanted && !always) return telemetry;
    const std::string bus = args.bus_name.empty() ? topic_name(input) : topic_name(args.bus_name);
    const auto fail = [&](const Error& error, int code) -> std::optional<Telemetry> {
        print_error(error);
        exit_code = code;
        return std::nullopt;
    };

    std::vector<std::unique_ptr<Exporter>> exporters;
    if (!args.mqtt.empty()) {
        auto url = parse_mqtt_url(args.mqtt);
        if (!url) return fail(Error{"--mqtt: " + url.error().message}, 2);
        MqttOptions options;
        options.url = *url;
        options.bus = bus;
        if (const char* user = std::getenv("RTUSCOPE_MQTT_USERNAME")) options.username = user;
        if (const char* password = std::getenv("RTUSCOPE_MQTT_PASSWORD")) {
            options.password = password;
        }
        if (!args.mqtt_password_file.empty()) {
            auto password = read_password(args.mqtt_password_file);
            if (!password) return fail(password.error(), 1);
            options.password = *password;
        }
        options.ca_file = args.mqtt_ca;
        options.cert_file = args.mqtt_cert;
        options.key_file = args.mqtt_key;
        options.interval = static_cast<Nanos>(std::llround(args.mqtt_interval_s * 1e9));
        options.ha_discovery = args.ha_discovery;
        options.ha_prefix = args.ha_prefix;
        options.required = args.mqtt_required;
        options.stop = &g_stop;
        auto mqtt = start_mqtt(options);
        if (!mqtt) return fail(mqtt.error(), 1);
        exporters.push_back(std::move(*mqtt));
    }
    if (!args.metrics.empty()) {
        auto listen = parse_listen_address(args.metrics);
        if (!listen) return fail(Error{"--metrics: " + listen.error().message}, 2);
        MetricsOptions options;
        options.listen = *listen;
        options.bus = bus;
        options.max_series = args.metrics_max_series;
        auto metrics = start_metrics(options, telemetry.shared);
        if (!metrics) return fail(metrics.error(), 1);
        fmt::print(stderr, "rtuscope: metrics on http://{}/metrics\n", metrics_endpoint(**metrics));
        exporters.push_back(std::move(*metrics));
    }
    auto sink = std::make_unique<TelemetrySink>(telemetry.shared, std::move(exporters));
    telemetry.sink = sink.get();
    std::vector<std::unique_ptr<RecordSink>> sinks;
    sinks.push_back(std::move(sink));
    if (decoding.sink) sinks.push_back(std::move(decoding.sink));
    decoding.sink = sinks.size() == 1 ? std::move(sinks.front()) : make_tee_sink(std::move(sinks));
    return telemetry;
}

int finish_telemetry(const Telemetry& telemetry) {
    if (telemetry.sink == nullptr) return 0;
    int code = 0;
    for (const auto& e : telemetry.sink->exporters()) {
        if (const std::string s = e->summary(); !s.empty()) fmt::print(stderr, "rtuscope: {}\n", s);
        if (e->failed()) code = 1;
    }
    return code;
}

}  // namespace rtuscope::cli
