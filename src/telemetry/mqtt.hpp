// MQTT: the bus's values, health and availability published to a broker (libmosquitto),
// with Home Assistant discovery. Publishing runs on a thread of its own behind a bounded
// queue: when the broker is slow or gone the oldest messages are dropped and counted.
#pragma once

#include <cstddef>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "telemetry/telemetry.hpp"
#include "util/result.hpp"

namespace rtuscope {

struct MqttUrl {
    bool tls = false;        // mqtts://
    std::string host;
    std::uint16_t port = 0;  // 1883, 8883 for mqtts
    std::string prefix;      // the path: "rtuscope" by default
};
// mqtt://host[:port][/prefix] or mqtts://...; an Error says what is wrong with it.
Result<MqttUrl> parse_mqtt_url(std::string_view text);

struct MqttOptions {
    MqttUrl url;
    std::string bus;                   // topic level: --bus-name, or the input's base name
    std::string username;              // RTUSCOPE_MQTT_USERNAME
    std::string password;              // --mqtt-password-file or RTUSCOPE_MQTT_PASSWORD
    std::string ca_file;               // --mqtt-ca
    std::string cert_file;             // --mqtt-cert (client certificate)
    std::string key_file;              // --mqtt-key
    Nanos interval = 60'000'000'000;   // --mqtt-interval: republish unchanged values
    bool ha_discovery = false;         // --ha-discovery
    std::string ha_prefix = "homeassistant";
    std::size_t queue_limit = 10000;   // messages waiting; beyond, the oldest are dropped
    // --mqtt-required: a broker that refuses the connection (credentials, TLS) stops the
    // run (sets *stop; failed() is then true, and the command exits 1) instead of going
    // on without MQTT.
    bool required = false;
    std::atomic<bool>* stop = nullptr;
};

// Connects in the background (never blocking the caller) and publishes until destroyed.
// An Error only for what cannot work at all (a CA file that cannot be read).
Result<std::unique_ptr<Exporter>> start_mqtt(const MqttOptions& options);

}  // namespace rtuscope
