// --mqtt ... and --metrics ...: the options that deliver the bus's state to a broker or
// to Prometheus (telemetry/), shared by sniff, demo, watch and decode.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <optional>
#include <string>

#include "output_options.hpp"
#include "telemetry/telemetry.hpp"

namespace rtuscope::cli {

struct TelemetryArgs {
    std::string bus_name;
    std::string mqtt;
    std::string mqtt_ca;
    std::string mqtt_cert;
    std::string mqtt_key;
    std::string mqtt_password_file;
    double mqtt_interval_s = 60;
    bool ha_discovery = false;
    std::string ha_prefix = "homeassistant";
    bool mqtt_required = false;
    std::string metrics;
    std::size_t metrics_max_series = 10000;
};

// `with_metrics`: decode replays at once, so a scrape would find it gone: MQTT only.
void add_telemetry_options(CLI::App& cmd, TelemetryArgs& args, bool with_metrics = true);

// The exporters the options ask for, started, in a sink that feeds them (and `shared`).
struct Telemetry {
    std::shared_ptr<SharedState> shared;
    TelemetrySink* sink = nullptr;  // inside Decoding::sink
};
// Puts the telemetry sink in front of `decoding.sink` (the state is fed before anything
// reads it). `input`: the port or file, whose base name names the bus by default.
// nullopt on an error (printed), with `exit_code` set: 2 for a bad option, 1 otherwise.
std::optional<Telemetry> attach_telemetry(const TelemetryArgs& args, std::string_view input,
                                          Decoding& decoding, int& exit_code,
                                          bool always = false);
// After the run: the exporters' summaries on stderr; 1 if one that was required failed.
int finish_telemetry(const Telemetry& telemetry);

}  // namespace rtuscope::cli
