// The telemetry sink: the names it gives topics and labels, and the dropped messages it
// carries from the MQTT exporter to watch's bus line and to the Prometheus metrics.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "input/sources.hpp"
#include "state/state_text.hpp"
#include "telemetry/metrics.hpp"
#include "telemetry/telemetry.hpp"

namespace rtuscope {
namespace {

TEST(TopicName, IsTheInputsBaseNameWithOnlySafeCharacters) {
    EXPECT_EQ(topic_name("/dev/ttyUSB0"), "ttyUSB0");
    EXPECT_EQ(topic_name("logs/field log.txt"), "field_log");
    EXPECT_EQ(topic_name("captures/seeds/pdu485.hex"), "pdu485");
    EXPECT_EQ(topic_name("bus#1+2"), "bus_1_2");
    EXPECT_EQ(topic_name(""), "bus");
}

// An exporter that says it dropped `n` messages, as the MQTT one does when its queue
// overflows.
class Dropping final : public Exporter {
  public:
    explicit Dropping(std::uint64_t n) : n_(n) {}
    void record(const BusState& /*state*/, const Record& /*record*/) override {}
    [[nodiscard]] std::optional<std::uint64_t> messages_dropped() const override { return n_; }

  private:
    std::uint64_t n_;
};

// The lines of a scrape that give the dropped count, after the seed PDU's capture went
// through a sink with `exporters` and a metrics exporter.
struct Fed {
    explicit Fed(std::vector<std::unique_ptr<Exporter>> exporters) {
        MetricsOptions options;
        options.listen = "127.0.0.1:0";
        options.bus = "seed";
        auto metrics = start_metrics(options, shared);
        EXPECT_TRUE(metrics);
        if (!metrics) return;
        scrape = metrics->get();
        exporters.push_back(std::move(*metrics));
        TelemetrySink sink(shared, std::move(exporters));
        std::ifstream in(std::string(RTUSCOPE_SOURCE_DIR) + "/captures/seeds/pdu485.hex");
        std::stringstream text;
        text << in.rdbuf();
        auto source = source_from_memory(text.str(), "seed", InputFormat::hex);
        EXPECT_TRUE(source);
        if (!source) return;
        EXPECT_TRUE(run_pipeline(**source, PipelineOptions{}, sink));
        dropped_lines = metrics_text(*scrape);
    }
    std::shared_ptr<SharedState> shared = std::make_shared<SharedState>();
    const Exporter* scrape = nullptr;
    std::string dropped_lines;
};

TEST(TelemetrySink, DroppedMessagesReachTheBusLineAndTheMetrics) {
    std::vector<std::unique_ptr<Exporter>> exporters;
    exporters.push_back(std::make_unique<Dropping>(3));
    Fed fed(std::move(exporters));
    EXPECT_EQ(fed.shared->state.messages_dropped(), 3U);
    EXPECT_NE(bus_line(fed.shared->state, StateView{}).find(", 3 MQTT messages dropped"),
              std::string::npos)
        << bus_line(fed.shared->state, StateView{});
    EXPECT_NE(fed.dropped_lines.find("\nrtuscope_mqtt_dropped_messages_total{bus=\"seed\"} 3\n"),
              std::string::npos)
        << fed.dropped_lines;
}

TEST(TelemetrySink, WithoutMqttNoDroppedCountIsShown) {
    Fed fed({});
    EXPECT_FALSE(fed.shared->state.messages_dropped().has_value());
    EXPECT_EQ(bus_line(fed.shared->state, StateView{}).find("dropped"), std::string::npos);
    EXPECT_EQ(fed.dropped_lines.find("rtuscope_mqtt_dropped_messages_total{"), std::string::npos)
        << fed.dropped_lines;
}

}  // namespace
}  // namespace rtuscope
