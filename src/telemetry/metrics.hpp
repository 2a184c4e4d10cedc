// Prometheus: `--metrics ADDR:PORT` serves /metrics in the Prometheus text format
// (prometheus-cpp's exposer), read from the shared bus state at each scrape.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "telemetry/telemetry.hpp"
#include "util/result.hpp"

namespace rtuscope {

struct MetricsOptions {
    std::string listen = "127.0.0.1:9464";  // ADDR:PORT; port 0: any free port
    std::string bus;                         // the `bus` label
    std::size_t max_series = 10000;          // register gauges; the rest are counted
};

// The exporter whose server runs until it is destroyed. An address that cannot be bound
// is an Error naming it.
Result<std::unique_ptr<Exporter>> start_metrics(const MetricsOptions& options,
                                                std::shared_ptr<SharedState> shared);

// "9464" and ":9464" listen on 127.0.0.1; "0.0.0.0:9464" and "[::1]:9464" as given.
Result<std::string> parse_listen_address(std::string_view text);

// Where the server listens once started ("127.0.0.1:40517"): for the message that tells
// the user, and for tests that asked for port 0.
std::string metrics_endpoint(const Exporter& metrics);

// What a scrape of /metrics reads now, in the Prometheus text format.
std::string metrics_text(const Exporter& metrics);

}  // namespace rtuscope
