// The MQTT exporter against a real broker (Debian's mosquitto, started per test): the
// retained values, health and availability it publishes, Home Assistant discovery, write
// events, reconnection with a full republish, a refused connection, and a broker that is
// not there.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <regex>
#include <string>
#include <thread>

#include "input/sources.hpp"
#include "mqtt_support.hpp"
#include "telemetry/mqtt.hpp"
#include "telemetry/telemetry.hpp"

namespace rtuscope {
namespace {

using namespace std::chrono_literals;
using test::Broker;
using test::Json;
using test::Subscriber;

#define REQUIRE_MOSQUITTO()                                                          \
    if (!test::have_mosquitto()) {                                                   \
        GTEST_SKIP() << "no MQTT broker to test against: " << test::kMosquitto       \
                     << " is missing (Debian package mosquitto)";                    \
    }

std::string seed(const std::string& name) {
    return std::string(RTUSCOPE_SOURCE_DIR) + "/captures/seeds/" + name;
}

// The records a capture gives, decoded with `bus`.
test::CollectingSink decode(const std::string& path, const Bus& bus) {
    test::CollectingSink out;
    auto source = open_source(path, InputFormat::automatic);
    EXPECT_TRUE(source) << source.error().to_string();
    if (!source) return out;
    PipelineOptions options;
    options.bus = &bus;
    EXPECT_TRUE(run_pipeline(**source, options, out));
    return out;
}

test::CollectingSink decode_text(std::string content, const Bus& bus) {
    test::CollectingSink out;
    auto source = source_from_memory(std::move(content), "mem", InputFormat::capture);
    EXPECT_TRUE(source) << source.error().to_string();
    if (!source) return out;
    PipelineOptions options;
    options.bus = &bus;
    EXPECT_TRUE(run_pipeline(**source, options, out));
    return out;
}

// A frame as a capture line's bytes: " 01 03 ...".
std::string hex(const test::Bytes& bytes) {
    std::string out;
    for (const auto b : bytes) out += fmt::format(" {:02X}", b);
    return out;
}

MqttOptions options_for(const std::string& url, const std::string& bus) {
    MqttOptions o;
    auto parsed = parse_mqtt_url(url);
    EXPECT_TRUE(parsed) << parsed.error().to_string();
    if (parsed) o.url = *parsed;
    o.bus = bus;
    return o;
}

// The exporter behind a TelemetrySink, as the pipeline drives it.
struct Exporting {
    explicit Exporting(const MqttOptions& options) {
        auto started = start_mqtt(options);
        EXPECT_TRUE(started) << started.error().to_string();
        if (!started) return;
        exporter = started->get();
        std::vector<std::unique_ptr<Exporter>> list;
        list.push_back(std::move(*started));
        sink = std::make_unique<TelemetrySink>(shared, std::move(list));
    }
    void feed(const test::CollectingSink& decoded) {
        sink->begin(decoded.session);
        for (const Record& r : decoded.records) sink->record(r);
    }
    void end() { sink->end({}, {}); }

    std::shared_ptr<SharedState> shared = std::make_shared<SharedState>();
    Exporter* exporter = nullptr;
    std::unique_ptr<TelemetrySink> sink;
};

Bus bus_of(std::initializer_list<std::pair<std::uint8_t, const char*>> devices) {
    Bus bus;
    for (const auto& [address, profile] : devices) EXPECT_TRUE(bus.assign(address, profile));
    return bus;
}

Json json_of(const std::optional<std::string>& payload) {
    EXPECT_TRUE(payload.has_value());
    if (!payload) return Json{};
    const std::optional<Json> j = Json::parse(*payload);
    EXPECT_TRUE(j.has_value()) << "not JSON: " << *payload;
    return j.value_or(Json{});
}

// Waits until every topic has had a message; those that have not, otherwise.
testing::AssertionResult wait_topics(Subscriber& s, const std::vector<std::string>& topics) {
    const auto missing = [&](const std::vector<Subscriber::Message>& all) {
        std::string out;
        for (const std::string& t : topics) {
            if (std::none_of(all.begin(), all.end(), [&](const auto& m) { return m.topic == t; })) {
                out += " " + t;
            }
        }
        return out;
    };
    if (s.wait([&](const auto& all) { return missing(all).empty(); })) {
        return testing::AssertionSuccess();
    }
    return testing::AssertionFailure() << "no message on" << missing(s.messages());
}

// The last message of every topic, retained ones as a new subscriber gets them.
std::map<std::string, Subscriber::Message> last_of_each(Subscriber& s) {
    std::map<std::string, Subscriber::Message> out;
    for (const auto& m : s.messages()) out[m.topic] = m;
    return out;
}

TEST(MqttUrl, HostPortAndPrefixWithTheirDefaults) {
    auto plain = parse_mqtt_url("mqtt://broker.local");
    ASSERT_TRUE(plain) << plain.error().to_string();
    EXPECT_FALSE(plain->tls);
    EXPECT_EQ(plain->host, "broker.local");
    EXPECT_EQ(plain->port, 1883);
    EXPECT_EQ(plain->prefix, "rtuscope");

    auto tls = parse_mqtt_url("mqtts://10.0.0.2:9883/plant/line1/");
    ASSERT_TRUE(tls) << tls.error().to_string();
    EXPECT_TRUE(tls->tls);
    EXPECT_EQ(tls->host, "10.0.0.2");
    EXPECT_EQ(tls->port, 9883);
    EXPECT_EQ(tls->prefix, "plant/line1");

    auto secure_default = parse_mqtt_url("mqtts://h");
    ASSERT_TRUE(secure_default);
    EXPECT_EQ(secure_default->port, 8883);

    auto v6 = parse_mqtt_url("mqtt://[::1]:1884/x");
    ASSERT_TRUE(v6) << v6.error().to_string();
    EXPECT_EQ(v6->host, "::1");
    EXPECT_EQ(v6->port, 1884);
    EXPECT_EQ(v6->prefix, "x");
}

TEST(MqttUrl, AnythingElseIsAnErrorSayingWhy) {
    const std::pair<const char*, const char*> cases[] = {
        {"http://broker", "must start with mqtt:// or mqtts://"},
        {"broker:1883", "must start with mqtt:// or mqtts://"},
        {"mqtt://", "has no host"},
        {"mqtt://:1883", "has no host"},
        {"mqtt://h:0", "port '0' is not a number from 1 to 65535"},
        {"mqtt://h:65536", "port '65536'"},
        {"mqtt://h:x1", "port 'x1'"},
        {"mqtt://h:", "port ''"},
        {"mqtt://user:pw@h", "credentials do not go in the URL"},
        {"mqtt://h/a/+/b", "holds '+'"},
        {"mqtt://h/a#", "holds '#'"},
        {"mqtt://h/a//b", "empty level"},
        {"mqtt://h/$SYS", "starts with '$'"},
        {"mqtt://::1/x", "IPv6 address goes in brackets"},
        {"mqtt://[::1/x", "no closing ']'"},
    };
    for (const auto& [url, why] : cases) {
        auto r = parse_mqtt_url(url);
        ASSERT_FALSE(r) << url;
        EXPECT_NE(r.error().message.find(why), std::string::npos)
            << url << ": " << r.error().message;
        EXPECT_NE(r.error().message.find(url), std::string::npos) << r.error().message;
    }
}

TEST(Mqtt, SettingsThatCannotWorkAreAnErrorAtStart) {
    MqttOptions o = options_for("mqtt://127.0.0.1:1", "b");
    o.ca_file = "/nonexistent/ca.pem";
    auto plain_with_ca = start_mqtt(o);
    ASSERT_FALSE(plain_with_ca);
    EXPECT_NE(plain_with_ca.error().message.find("use mqtts://"), std::string::npos);

    o.url.tls = true;
    auto missing_ca = start_mqtt(o);
    ASSERT_FALSE(missing_ca);
    EXPECT_NE(missing_ca.error().message.find("cannot read the CA file '/nonexistent/ca.pem'"),
              std::string::npos)
        << missing_ca.error().message;

    MqttOptions p = options_for("mqtt://127.0.0.1:1", "b");
    p.password = "secret";
    auto no_user = start_mqtt(p);
    ASSERT_FALSE(no_user);
    EXPECT_NE(no_user.error().message.find("needs a user name"), std::string::npos);
}

// Every register of the three seed devices ends up retained on its topic with its value
// (a JSON number where it is one), unit and raw words; the bus says offline at the end.
TEST(Mqtt, RetainedValuesAreTheDecodedValuesWithTheirUnits) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    const Bus uv = bus_of({{1, "zb-uvi485"}, {2, "zb-uvi485"}, {3, "zb-uvi485"}});
    const Bus pdu = bus_of({{1, "pdu485"}});
    const Bus relay = bus_of({{5, "zyi-relay"}});
    const std::pair<std::string, const Bus*> runs[] = {
        {"zb-uvi485.hex", &uv}, {"pdu485.hex", &pdu}, {"zyi-relay.hex", &relay}};
    std::vector<std::unique_ptr<Exporting>> done;
    for (const auto& [file, bus] : runs) {
        auto e = std::make_unique<Exporting>(options_for(broker.url(), topic_name(file)));
        ASSERT_NE(e->exporter, nullptr);
        e->feed(decode(seed(file), *bus));
        e->end();
        EXPECT_FALSE(e->exporter->failed());
        EXPECT_NE(e->exporter->summary().find(" 0 dropped"), std::string::npos)
            << e->exporter->summary();
        done.push_back(std::move(e));
    }

    // Every register the states hold, on its topic.
    struct Expected {
        std::string topic;
        const BusState* state;
        const RegisterState* r;
    };
    std::vector<Expected> expected;
    std::vector<std::string> commands;
    for (std::size_t i = 0; i < done.size(); ++i) {
        const BusState& state = done[i]->shared->state;
        for (const SlaveState* s : state.slaves()) {
            for (const RegisterState* r : state.registers(s->address)) {
                // Commands written into number registers (clear the energy counter, all
                // relays on): events, not values; checked below.
                const Register* reg =
                    s->profile == nullptr
                        ? nullptr
                        : s->profile->register_at(std::string(state.table_name(r->key.table)),
                                                  r->key.address);
                if (r->written && !r->numeric && reg != nullptr && reg->type != ValueType::enumeration &&
                    reg->type != ValueType::bits && reg->type != ValueType::string) {
                    commands.push_back(fmt::format("rtuscope/{}/{}/{}", topic_name(runs[i].first),
                                                   s->address, state.text(r->name)));
                    continue;
                }
                const std::string name(state.text(r->name));
                expected.push_back(
                    {fmt::format("rtuscope/{}/{}/{}", topic_name(runs[i].first), s->address,
                                 name.empty() ? fmt::format("{}_0x{:04x}",
                                                            state.table_name(r->key.table),
                                                            r->key.address)
                                              : name),
                     &state, r});
            }
        }
    }
    EXPECT_GT(expected.size(), 40U);
    std::vector<std::string> topics = {"rtuscope/pdu485/$status", "rtuscope/pdu485/1/$status",
                                       "rtuscope/pdu485/1/$health", "rtuscope/zb-uvi485/2/$health",
                                       "rtuscope/pdu485/$bus"};
    for (const auto& x : expected) topics.push_back(x.topic);

    Subscriber sub(broker.port(), "rtuscope/#");
    ASSERT_TRUE(sub.ready());
    ASSERT_TRUE(wait_topics(sub, topics));

    const Json uv1 = json_of(sub.last("rtuscope/zb-uvi485/1/uv_intensity"));
    ASSERT_TRUE(uv1.has("value"));
    ASSERT_TRUE(uv1["value"].is_number());
    EXPECT_DOUBLE_EQ(uv1["value"].number(), 616.8);
    EXPECT_EQ(uv1["unit"].string(), "µW/cm²");
    EXPECT_EQ(uv1["raw"].string(), "0x1818");
    EXPECT_TRUE(uv1["time"].is_null());  // a hex log has no times

    const Json volts = json_of(sub.last("rtuscope/pdu485/1/voltage"));
    EXPECT_DOUBLE_EQ(volts["value"].number(), 220.5);
    EXPECT_EQ(volts["unit"].string(), "V");
    EXPECT_EQ(volts["raw"].string(), "0x089D");

    // A command word written into the energy counter is not its value: the last read is.
    const Json energy = json_of(sub.last("rtuscope/pdu485/1/energy"));
    EXPECT_DOUBLE_EQ(energy["value"].number(), 12345.0);
    EXPECT_EQ(energy["unit"].string(), "kWh");
    EXPECT_EQ(energy["raw"].string(), "0x0000 0x3039");

    const Json relay1 = json_of(sub.last("rtuscope/zyi-relay/5/relay1"));
    ASSERT_TRUE(relay1["value"].is_string());
    EXPECT_TRUE(relay1["value"].string() == "on" || relay1["value"].string() == "off");

    const auto retained = last_of_each(sub);
    EXPECT_EQ(commands, (std::vector<std::string>{"rtuscope/pdu485/1/energy",
                                                  "rtuscope/zyi-relay/5/all_off",
                                                  "rtuscope/zyi-relay/5/all_on"}));
    EXPECT_FALSE(retained.contains("rtuscope/zyi-relay/5/all_on"));
    for (const auto& [topic, state, r] : expected) {
        const auto it = retained.find(topic);
        ASSERT_NE(it, retained.end()) << topic;
        EXPECT_TRUE(it->second.retained) << topic;
        const Json j = json_of(it->second.payload);
        if (r->numeric) {
            ASSERT_TRUE(j["value"].is_number()) << topic << " " << it->second.payload;
            EXPECT_FLOAT_EQ(static_cast<float>(j["value"].number()),
                            std::strtof(r->value.c_str(), nullptr))
                << topic;
        } else {
            ASSERT_TRUE(j["value"].is_string()) << topic;
            EXPECT_EQ(j["value"].string(), r->value) << topic;
        }
        EXPECT_EQ(j["unit"].string(), state->text(r->unit)) << topic;
    }

    EXPECT_EQ(sub.last("rtuscope/pdu485/$status"), "offline");
    EXPECT_EQ(sub.last("rtuscope/pdu485/1/$status"), "online");
    const Json health = json_of(sub.last("rtuscope/pdu485/1/$health"));
    for (const char* key : {"requests", "answered", "turnaround_p50_ms", "turnaround_p95_ms",
                            "exceptions", "no_answer", "crc_errors", "last_seen"}) {
        EXPECT_TRUE(health.has(key)) << key;
    }
    EXPECT_EQ(health["exceptions"].number(), 1.0);  // the read of 101 registers
    const Json uv_health = json_of(sub.last("rtuscope/zb-uvi485/2/$health"));
    EXPECT_EQ(uv_health["crc_errors"].number(), 1.0);  // the manual's typo
    const Json bus = json_of(sub.last("rtuscope/pdu485/$bus"));
    for (const char* key : {"frames", "utilisation", "errors", "dropped"}) {
        EXPECT_TRUE(bus.has(key)) << key;
    }
    EXPECT_EQ(bus["frames"].number(), static_cast<double>(done[1]->shared->state.stats().bus().frames));
}

TEST(Mqtt, DiscoveryConfigsNameUnitsClassesDeviceAndAvailability) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    const Bus pdu = bus_of({{1, "pdu485"}});
    const Bus relay = bus_of({{5, "zyi-relay"}});
    const Bus uv = bus_of({{1, "zb-uvi485"}});
    for (const auto& [file, bus] :
         {std::pair{"pdu485.hex", &pdu}, std::pair{"zyi-relay.hex", &relay},
          std::pair{"zb-uvi485.hex", &uv}}) {
        MqttOptions o = options_for(broker.url(), topic_name(file));
        o.ha_discovery = true;
        o.ha_prefix = "ha";
        Exporting e(o);
        ASSERT_NE(e.exporter, nullptr);
        e.feed(decode(seed(file), *bus));
        e.end();
    }
    Subscriber sub(broker.port(), "ha/#");
    ASSERT_TRUE(sub.ready());
    ASSERT_TRUE(wait_topics(
        sub, {"ha/sensor/rtuscope_zb-uvi485_1_uv_intensity/config",
              "ha/sensor/rtuscope_pdu485_1_voltage/config", "ha/sensor/rtuscope_pdu485_utilisation/config",
              "ha/sensor/rtuscope_pdu485_1_current/config", "ha/sensor/rtuscope_pdu485_1_power/config",
              "ha/sensor/rtuscope_pdu485_1_energy/config", "ha/sensor/rtuscope_pdu485_1_temperature1/config",
              "ha/sensor/rtuscope_pdu485_1_humidity1/config", "ha/sensor/rtuscope_pdu485_1_power_factor/config",
              "ha/sensor/rtuscope_pdu485_1_display_mode/config",
              "ha/binary_sensor/rtuscope_zyi-relay_5_relay1/config"}));
    const auto configs = last_of_each(sub);
    for (const auto& [topic, m] : configs) {
        EXPECT_TRUE(m.retained) << topic;
        EXPECT_TRUE(Json::parse(m.payload).has_value()) << topic << ": " << m.payload;
    }
    const auto config = [&](const std::string& topic) {
        const auto it = configs.find(topic);
        EXPECT_NE(it, configs.end()) << topic;
        return it == configs.end() ? Json{} : json_of(it->second.payload);
    };

    const Json volts = config("ha/sensor/rtuscope_pdu485_1_voltage/config");
    EXPECT_EQ(volts["name"].string(), "voltage");
    EXPECT_EQ(volts["unique_id"].string(), "rtuscope_pdu485_1_voltage");
    EXPECT_EQ(volts["state_topic"].string(), "rtuscope/pdu485/1/voltage");
    EXPECT_EQ(volts["value_template"].string(), "{{ value_json.value }}");
    EXPECT_EQ(volts["unit_of_measurement"].string(), "V");
    EXPECT_EQ(volts["device_class"].string(), "voltage");
    EXPECT_EQ(volts["state_class"].string(), "measurement");
    ASSERT_EQ(volts["availability"].array().size(), 2U);
    EXPECT_EQ(volts["availability"].array()[0]["topic"].string(), "rtuscope/pdu485/$status");
    EXPECT_EQ(volts["availability"].array()[1]["topic"].string(), "rtuscope/pdu485/1/$status");
    const Json& device = volts["device"];
    ASSERT_EQ(device["identifiers"].array().size(), 1U);
    EXPECT_EQ(device["identifiers"].array()[0].string(), "rtuscope_pdu485_1");
    EXPECT_EQ(device["name"].string(), "slave 1 (pdu485)");
    EXPECT_EQ(device["model"].string(), "pdu485");
    EXPECT_EQ(device["via_device"].string(), "rtuscope_pdu485");
    // The device it is reached through is announced too.
    const Json bridge = config("ha/sensor/rtuscope_pdu485_utilisation/config");
    EXPECT_EQ(bridge["device"]["identifiers"].array()[0].string(), "rtuscope_pdu485");

    // "device_class/state_class", either empty when absent.
    const auto classes = [&](const std::string& reg) {
        const Json j = config("ha/sensor/rtuscope_pdu485_1_" + reg + "/config");
        return (j.has("device_class") ? j["device_class"].string() : std::string()) + "/" +
               (j.has("state_class") ? j["state_class"].string() : std::string());
    };
    EXPECT_EQ(classes("current"), "current/measurement");
    EXPECT_EQ(classes("power"), "power/measurement");
    EXPECT_EQ(classes("energy"), "energy/total_increasing");
    EXPECT_EQ(classes("temperature1"), "temperature/measurement");
    EXPECT_EQ(classes("humidity1"), "humidity/measurement");
    EXPECT_EQ(classes("power_factor"), "/measurement");
    // A label, not a number: no unit, no class.
    EXPECT_EQ(classes("display_mode"), "/");

    const Json uv_config = config("ha/sensor/rtuscope_zb-uvi485_1_uv_intensity/config");
    EXPECT_EQ(uv_config["unit_of_measurement"].string(), "µW/cm²");
    EXPECT_FALSE(uv_config.has("device_class"));
    EXPECT_EQ(uv_config["state_class"].string(), "measurement");
    EXPECT_EQ(uv_config["device"]["name"].string(), "slave 1 (zb-uvi485)");

    // Relay states are on/off: binary sensors.
    const Json relay1 = config("ha/binary_sensor/rtuscope_zyi-relay_5_relay1/config");
    EXPECT_EQ(relay1["payload_on"].string(), "on");
    EXPECT_EQ(relay1["payload_off"].string(), "off");
    EXPECT_FALSE(relay1.has("unit_of_measurement"));
    EXPECT_EQ(configs.count("ha/sensor/rtuscope_zyi-relay_5_relay1/config"), 0U);
}

// A bit field is one binary sensor per named bit, read from the payload's "bits"; a
// profile's home_assistant classes win over those its unit implies.
TEST(Mqtt, BitFieldsAreBinarySensorsPerBitAndTheProfileOverridesClasses) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    ProfileLoad load = load_profile_text(R"(
[device]
name = "heat-pump"
title = "a heat pump"
[[register]]
address = 0
name = "status"
type = "bits"
bits = { "0" = "compressor", "3" = "defrost", "15" = "alarm" }
[[register]]
address = 1
name = "energy_today"
unit = "kWh"
home_assistant = { state_class = "total" }
[[register]]
address = 2
name = "flow_temperature"
unit = "°C"
home_assistant = { device_class = "", state_class = "" }
[[register]]
address = 3
name = "outdoor_temperature"
unit = "°C"
)",
                                         "heat-pump.toml");
    ASSERT_TRUE(load.profile) << (load.problems.empty() ? "" : load.problems[0].to_string());
    Bus bus;
    bus.add_profile(std::move(*load.profile));
    ASSERT_TRUE(bus.assign(7, "heat-pump"));
    // Bits 0 and 15 set (0x8001); 12 kWh, 35 and 5 °C.
    const std::string capture =
        "# rtuscope capture v1\n# serial 9600 8N1\n0.000" +
        hex(test::with_crc({7, 3, 0, 0, 0, 4})) + "\n0.030" +
        hex(test::with_crc({7, 3, 8, 0x80, 0x01, 0, 12, 0, 35, 0, 5})) + "\n";

    MqttOptions o = options_for(broker.url(), "hp");
    o.ha_discovery = true;
    o.ha_prefix = "ha";
    Exporting e(o);
    ASSERT_NE(e.exporter, nullptr);
    e.feed(decode_text(capture, bus));
    e.end();
    Subscriber sub(broker.port(), "#");
    ASSERT_TRUE(sub.ready());
    const std::string bit_topic = "ha/binary_sensor/rtuscope_hp_7_status_";
    ASSERT_TRUE(wait_topics(sub, {"rtuscope/hp/7/status", bit_topic + "compressor/config",
                                  bit_topic + "defrost/config", bit_topic + "alarm/config",
                                  "ha/sensor/rtuscope_hp_7_status/config",
                                  "ha/sensor/rtuscope_hp_7_energy_today/config",
                                  "ha/sensor/rtuscope_hp_7_flow_temperature/config",
                                  "ha/sensor/rtuscope_hp_7_outdoor_temperature/config"}));
    const auto last = last_of_each(sub);
    const auto payload = [&](const std::string& topic) {
        const auto it = last.find(topic);
        return it == last.end() ? Json{} : json_of(it->second.payload);
    };

    // The value: the set bits' names; "bits": each named bit's state.
    const Json status = payload("rtuscope/hp/7/status");
    EXPECT_EQ(status["raw"].string(), "0x8001");
    EXPECT_EQ(status["bits"]["compressor"].number(), 1);
    EXPECT_EQ(status["bits"]["defrost"].number(), 0);
    EXPECT_EQ(status["bits"]["alarm"].number(), 1);

    const Json defrost = payload(bit_topic + "defrost/config");
    EXPECT_EQ(defrost["name"].string(), "status defrost");
    EXPECT_EQ(defrost["unique_id"].string(), "rtuscope_hp_7_status_defrost");
    EXPECT_EQ(defrost["state_topic"].string(), "rtuscope/hp/7/status");
    EXPECT_EQ(defrost["value_template"].string(),
              "{{ 'ON' if value_json.bits[\"defrost\"] else 'OFF' }}");
    EXPECT_EQ(defrost["payload_on"].string(), "ON");
    EXPECT_EQ(defrost["device"]["model"].string(), "heat-pump");
    EXPECT_EQ(defrost["availability"].array().size(), 2U);

    const auto classes = [&](const std::string& reg) {
        const Json j = payload("ha/sensor/rtuscope_hp_7_" + reg + "/config");
        return (j.has("device_class") ? j["device_class"].string() : std::string()) + "/" +
               (j.has("state_class") ? j["state_class"].string() : std::string());
    };
    EXPECT_EQ(classes("energy_today"), "energy/total");  // the class its unit implies, the profile's state class
    EXPECT_EQ(classes("flow_temperature"), "/");       // none, as the profile says
    EXPECT_EQ(classes("outdoor_temperature"), "temperature/measurement");
}

// Writes on the bus are events, not state: not retained, with the write request's number.
TEST(Mqtt, WritesAreEventsThatAreNotRetained) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    Subscriber live(broker.port(), "rtuscope/#");
    ASSERT_TRUE(live.ready());
    const Bus pdu = bus_of({{1, "pdu485"}});
    Exporting e(options_for(broker.url(), "pdu"));
    ASSERT_NE(e.exporter, nullptr);
    const auto decoded = decode(seed("pdu485.hex"), pdu);
    e.feed(decoded);
    e.end();
    const Json alarm = json_of(live.last("rtuscope/pdu/1/voltage_high_alarm/$write"));
    EXPECT_DOUBLE_EQ(alarm["value"].number(), 264.0);
    EXPECT_EQ(alarm["unit"].string(), "V");
    EXPECT_EQ(alarm["request"].number(), 5.0);  // the FC10 request is record 5
    const Json clear = json_of(live.last("rtuscope/pdu/1/energy/$write"));
    EXPECT_EQ(clear["value"].string(), "clear the energy counter");
    EXPECT_EQ(clear["raw"].string(), "0xAABB");
    for (const auto& m : live.messages()) {
        if (m.topic.ends_with("/$write")) {
            EXPECT_FALSE(m.retained) << m.topic;
        }
    }
    // A new subscriber gets the state, not the events.
    Subscriber later(broker.port(), "rtuscope/#");
    ASSERT_TRUE(later.ready());
    ASSERT_TRUE(later.last("rtuscope/pdu/$status").has_value());
    for (const auto& m : later.messages()) EXPECT_FALSE(m.topic.ends_with("/$write")) << m.topic;
}

TEST(Mqtt, BusStatusIsOnlineWhileRunningAndOfflineAfterEnd) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    Subscriber sub(broker.port(), "rtuscope/b/$status");
    ASSERT_TRUE(sub.ready());
    const Bus pdu = bus_of({{1, "pdu485"}});
    Exporting e(options_for(broker.url(), "b"));
    ASSERT_NE(e.exporter, nullptr);
    e.feed(decode(seed("pdu485.hex"), pdu));
    EXPECT_TRUE(sub.wait([](const auto& all) { return !all.empty() && all.back().payload == "online"; }));
    e.end();
    EXPECT_TRUE(sub.wait([](const auto& all) { return !all.empty() && all.back().payload == "offline"; }));
    EXPECT_NE(e.exporter->summary().find("messages published, 0 dropped"), std::string::npos)
        << e.exporter->summary();
}

// A sniffer that dies (no end(), no clean disconnect) is marked offline by the broker,
// with the last will set before connecting.
TEST(Mqtt, LastWillSaysOfflineWhenTheSnifferDies) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    const std::string url = broker.url();
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        auto exporter = start_mqtt(options_for(url, "dying"));
        if (!exporter) ::_exit(1);
        for (;;) ::pause();
    }
    Subscriber sub(broker.port(), "rtuscope/dying/$status");
    ASSERT_TRUE(sub.ready());
    const bool online = sub.wait([](const auto& all) { return !all.empty() && all.back().payload == "online"; });
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    ASSERT_TRUE(online);
    EXPECT_TRUE(sub.wait([](const auto& all) { return all.back().payload == "offline"; }));
    Subscriber later(broker.port(), "rtuscope/dying/$status");
    ASSERT_TRUE(later.ready());
    EXPECT_EQ(later.last("rtuscope/dying/$status"), "offline");
}

// The broker goes away (losing every retained message) and comes back: the exporter
// reconnects and publishes the whole state again; what did not fit in its queue meanwhile
// is dropped, oldest first, and counted.
TEST(Mqtt, ReconnectsAfterTheBrokerRestartsAndRepublishesTheState) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    const Bus bus = bus_of({{1, "pdu485"}, {5, "zyi-relay"}});
    MqttOptions o = options_for(broker.url(), "r");
    o.queue_limit = 64;
    Exporting e(o);
    ASSERT_NE(e.exporter, nullptr);
    {
        Subscriber sub(broker.port(), "rtuscope/r/1/voltage");
        ASSERT_TRUE(sub.ready());
        e.feed(decode(seed("pdu485.hex"), bus));
        // What overflowed the queue before the first connection comes with its republish.
        bool arrived = false;
        for (int i = 0; i < 100 && !arrived; ++i) {
            e.sink->idle(kNoTime);
            arrived = sub.last("rtuscope/r/1/voltage", 50ms).has_value();
        }
        ASSERT_TRUE(arrived);
    }
    broker.stop();
    // The relays switched on and off, three times over, while no broker is there: more
    // messages than the queue holds (but not more than a full republish needs).
    const auto relays = decode(seed("zyi-relay.hex"), bus);
    for (int i = 0; i < 3; ++i) {
        for (const Record& r : relays.records) e.sink->record(r);
    }
    ASSERT_TRUE(broker.start());

    Subscriber sub(broker.port(), "rtuscope/r/#");
    ASSERT_TRUE(sub.ready());
    // The republish is the pipeline thread's: it comes with the next record or idle tick.
    const auto deadline = std::chrono::steady_clock::now() + 8s;
    bool republished = false;
    while (!republished && std::chrono::steady_clock::now() < deadline) {
        e.sink->idle(kNoTime);
        republished = sub.wait(
            [](const auto& all) {
                bool volts = false;
                bool relay = false;
                bool health = false;  // the republish's $bus, with the count dropped meanwhile
                for (const auto& m : all) {
                    volts = volts || m.topic == "rtuscope/r/1/voltage";
                    relay = relay || m.topic == "rtuscope/r/5/relay12";
                    health = health || m.topic == "rtuscope/r/$bus";
                }
                return volts && relay && health;
            },
            50ms);
    }
    ASSERT_TRUE(republished) << broker.log();
    EXPECT_EQ(sub.last("rtuscope/r/$status"), "online");
    const Json volts = json_of(sub.last("rtuscope/r/1/voltage"));
    EXPECT_DOUBLE_EQ(volts["value"].number(), 220.5);
    const Json health = json_of(sub.last("rtuscope/r/$bus"));
    EXPECT_GT(health["dropped"].number(), 0.0);
    e.end();
    const std::string summary = e.exporter->summary();
    std::smatch m;
    ASSERT_TRUE(std::regex_search(summary, m, std::regex(R"(mqtt: (\d+) messages published, (\d+) dropped)")))
        << summary;
    EXPECT_GT(std::stoul(m[1]), 0U);
    EXPECT_GT(std::stoul(m[2]), 0U) << summary;
    EXPECT_EQ(summary.find("never connected"), std::string::npos);
}

// A wrong password: one line on stderr however often it is retried, and with
// --mqtt-required the run is stopped and counts as failed. The right one gets through.
TEST(Mqtt, RefusedConnectionSaysSoOnceAndFailsWhenRequired) {
    REQUIRE_MOSQUITTO();
    Broker broker(Broker::User{"sniffer", "right"});
    ASSERT_TRUE(broker.start());
    std::atomic<bool> stop{false};
    MqttOptions o = options_for(broker.url(), "auth");
    o.username = "sniffer";
    o.password = "wrong";
    o.required = true;
    o.stop = &stop;
    testing::internal::CaptureStderr();
    std::string err;
    {
        Exporting e(o);
        ASSERT_NE(e.exporter, nullptr);
        const auto deadline = std::chrono::steady_clock::now() + 5s;
        while (!stop && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
        // Long enough for the next attempts (0.25 s, 0.5 s later).
        std::this_thread::sleep_for(1200ms);
        EXPECT_TRUE(stop);
        EXPECT_TRUE(e.exporter->failed());
        e.end();
        EXPECT_NE(e.exporter->summary().find("never connected"), std::string::npos)
            << e.exporter->summary();
        err = testing::internal::GetCapturedStderr();
    }
    const std::string line = fmt::format(
        "rtuscope: mqtt: broker 127.0.0.1:{} refused the connection: not authorised\n", broker.port());
    EXPECT_NE(err.find(line), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;  // the command prints the summary
    // It did retry: the broker turned it away more than once.
    const std::string log = broker.log();
    std::size_t refusals = 0;
    for (std::size_t at = log.find("not authorised"); at != std::string::npos;
         at = log.find("not authorised", at + 1)) {
        ++refusals;
    }
    EXPECT_GE(refusals, 2U) << log;

    o.password = "right";
    std::atomic<bool> stop_ok{false};
    o.stop = &stop_ok;
    Exporting ok(o);
    ASSERT_NE(ok.exporter, nullptr);
    const Bus pdu = bus_of({{1, "pdu485"}});
    ok.feed(decode(seed("pdu485.hex"), pdu));
    ok.end();
    EXPECT_FALSE(stop_ok);
    EXPECT_FALSE(ok.exporter->failed());
    EXPECT_EQ(ok.exporter->summary().find("never connected"), std::string::npos)
        << ok.exporter->summary();
}

// mqtts:// with the CA that signed the broker's certificate connects; with another CA the
// broker is not trusted: one line says why, and a required exporter fails the run.
TEST(Mqtt, TlsConnectsWithTheRightCaAndIsRefusedWithAnother) {
    REQUIRE_MOSQUITTO();
    test::TempDir dir;
    const auto server = test::make_certificates(dir, "server");
    const auto other = test::make_certificates(dir, "other");
    if (!server || !other) GTEST_SKIP() << "openssl could not make test certificates";
    Broker broker(std::nullopt, server);
    ASSERT_TRUE(broker.start()) << broker.log();
    const std::string url = fmt::format("mqtts://127.0.0.1:{}", broker.port());
    const Bus pdu = bus_of({{1, "pdu485"}});
    const auto decoded = decode(seed("pdu485.hex"), pdu);

    MqttOptions o = options_for(url, "tls");
    o.ca_file = server->ca;
    {
        Exporting e(o);
        ASSERT_NE(e.exporter, nullptr);
        e.feed(decoded);
        e.end();
        const std::string summary = e.exporter->summary();
        EXPECT_EQ(summary.find("never connected"), std::string::npos) << summary << broker.log();
        EXPECT_EQ(summary.find("mqtt: 0 messages"), std::string::npos) << summary;
        EXPECT_NE(summary.find(" 0 dropped"), std::string::npos) << summary;
    }

    std::atomic<bool> stop{false};
    o.ca_file = other->ca;
    o.required = true;
    o.stop = &stop;
    testing::internal::CaptureStderr();
    Exporting e(o);
    ASSERT_NE(e.exporter, nullptr);
    const auto deadline = std::chrono::steady_clock::now() + 5s;
    while (!stop && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
    std::this_thread::sleep_for(800ms);  // and retries
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_TRUE(stop);
    EXPECT_TRUE(e.exporter->failed());
    EXPECT_NE(err.find(fmt::format("rtuscope: mqtt: broker 127.0.0.1:{} refused the connection: TLS",
                                   broker.port())),
              std::string::npos)
        << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
}

// Past BusState::kMaxRegisters the least recently updated register gives its slot to a
// new one: that is a register never published, whatever value the slot held before.
TEST(Mqtt, ARegisterInAReusedSlotIsPublishedAsANewRegister) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    Subscriber sub(broker.port(), "rtuscope/evict/$status");
    ASSERT_TRUE(sub.ready());
    // Slave 1's 65536 holding registers, all 0, 125 a read; then slave 2's register 0,
    // also 0, which takes the slot of slave 1's register 0.
    std::string capture = "# rtuscope capture v1\n# serial 115200 8N1\n";
    int second = 0;
    const auto read = [&](std::uint8_t slave, unsigned start, unsigned count) {
        capture += fmt::format("{}.000{}\n", second,
                               hex(test::with_crc({slave, 3, static_cast<std::uint8_t>(start >> 8),
                                                   static_cast<std::uint8_t>(start & 0xFF), 0,
                                                   static_cast<std::uint8_t>(count)})));
        test::Bytes answer = {slave, 3, static_cast<std::uint8_t>(2 * count)};
        answer.resize(answer.size() + 2 * count, 0);
        capture += fmt::format("{}.100{}\n", second, hex(test::with_crc(answer)));
        ++second;
    };
    for (unsigned start = 0; start < 65536; start += 125) read(1, start, std::min(125U, 65536 - start));
    read(2, 0, 1);
    const Bus none;
    const auto decoded = decode_text(capture, none);

    MqttOptions o = options_for(broker.url(), "evict");
    o.interval = 1'000'000 * kNanosPerSecond;
    o.queue_limit = 100;
    Exporting e(o);
    ASSERT_NE(e.exporter, nullptr);
    // Connected first, so that the republish a connection brings comes before the records
    // and does not publish the new register on its own.
    ASSERT_TRUE(sub.wait([](const auto& all) { return !all.empty() && all.back().payload == "online"; }));
    e.sink->begin(decoded.session);
    for (const Record& r : decoded.records) e.sink->record(r);
    ASSERT_EQ(e.shared->state.forgotten_registers(), 1U);
    e.end();
    // Read as retained by a subscriber that comes after: the broker drops messages for a
    // subscriber that falls behind 65536 of them, and the one sought comes last.
    Subscriber later(broker.port(), "rtuscope/evict/2/#");
    ASSERT_TRUE(later.ready());
    const auto payload = later.last("rtuscope/evict/2/holding_0x0000");
    ASSERT_TRUE(payload.has_value()) << "slave 2's register 0 was never published";
    const Json reg = json_of(payload);
    EXPECT_DOUBLE_EQ(reg["value"].number(), 0.0);
    EXPECT_EQ(reg["raw"].string(), "0x0000");
}

// No broker at all: the pipeline's calls return at once, the end comes within its bound,
// and the summary says where it never connected.
TEST(Mqtt, AnAbsentBrokerNeverBlocksThePipeline) {
    const std::uint16_t port = test::free_port();
    MqttOptions o = options_for(fmt::format("mqtt://127.0.0.1:{}", port), "gone");
    o.ha_discovery = true;
    Exporting e(o);
    ASSERT_NE(e.exporter, nullptr);
    const Bus pdu = bus_of({{1, "pdu485"}});
    const auto decoded = decode(seed("pdu485.hex"), pdu);
    e.sink->begin(decoded.session);
    for (const Record& r : decoded.records) {
        const auto start = std::chrono::steady_clock::now();
        e.sink->record(r);
        EXPECT_LT(std::chrono::steady_clock::now() - start, 100ms);
    }
    const auto start = std::chrono::steady_clock::now();
    e.end();
    EXPECT_LT(std::chrono::steady_clock::now() - start, 3s);
    const std::string summary = e.exporter->summary();
    EXPECT_NE(summary.find(fmt::format("mqtt: 0 messages published, ")), std::string::npos) << summary;
    EXPECT_NE(summary.find(fmt::format("never connected to 127.0.0.1:{}", port)), std::string::npos)
        << summary;
    EXPECT_EQ(summary.find(" 0 dropped"), std::string::npos) << summary;  // all queued, never sent
}

// A slave polled every second: offline once it has missed 3 cycles, online at its next
// answer; an unchanged value is published again at each interval of the records' clock.
TEST(Mqtt, SlaveIsOfflineAfterThreeMissedPollCyclesAndOnlineAtItsNextAnswer) {
    REQUIRE_MOSQUITTO();
    Broker broker;
    ASSERT_TRUE(broker.start());
    Subscriber sub(broker.port(), "rtuscope/t/#");
    ASSERT_TRUE(sub.ready());
    std::string capture = "# rtuscope capture v1\n# serial 9600 8N1\n";
    for (int second = 0; second <= 16; ++second) {
        capture += fmt::format("{}.000{}\n", second, hex(test::with_crc({1, 3, 0, 0, 0, 1})));
        const bool answers = second <= 4 || second >= 12;
        if (answers) {
            capture += fmt::format("{}.030{}\n", second, hex(test::with_crc({1, 3, 2, 0x08, 0xFD})));
        }
    }
    const Bus bus = bus_of({{1, "pdu485"}});
    MqttOptions o = options_for(broker.url(), "t");
    o.interval = 3 * kNanosPerSecond;
    Exporting e(o);
    ASSERT_NE(e.exporter, nullptr);
    e.feed(decode_text(capture, bus));
    e.end();
    ASSERT_TRUE(sub.wait([](const auto& all) { return !all.empty() && all.back().payload == "offline" &&
                                                      all.back().topic == "rtuscope/t/$status"; }));
    std::vector<std::string> statuses;
    std::size_t voltages = 0;
    for (const auto& m : sub.messages()) {
        // Its changes: a republish (after the connection) repeats the current one.
        if (m.topic == "rtuscope/t/1/$status" && (statuses.empty() || statuses.back() != m.payload)) {
            statuses.push_back(m.payload);
        }
        if (m.topic == "rtuscope/t/1/$health") {
            // The first request starts 9 characters before 0.000, at -0.009 s.
            const Json health = json_of(m.payload);
            ASSERT_TRUE(health["last_seen"].is_number()) << m.payload;
            EXPECT_GT(health["last_seen"].number(), -0.01) << m.payload;
        }
        if (m.topic == "rtuscope/t/1/voltage") {
            ++voltages;
            EXPECT_DOUBLE_EQ(json_of(m.payload)["value"].number(), 230.1);
            EXPECT_TRUE(json_of(m.payload)["time"].is_number());
            EXPECT_GE(json_of(m.payload)["time"].number(), 0.0);
        }
    }
    EXPECT_EQ(statuses, (std::vector<std::string>{"online", "offline", "online"}));
    // 230.1 V throughout, published at 0 s, then at least every 3 s of the 16.
    EXPECT_GE(voltages, 4U);
    EXPECT_LE(voltages, 8U);
}

}  // namespace
}  // namespace rtuscope
