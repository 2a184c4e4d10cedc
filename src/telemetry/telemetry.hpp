// Stage 5c, telemetry: the bus's state (state/bus_state.hpp) delivered, read-only, to the
// systems people already run: an MQTT broker (mqtt.hpp, with Home Assistant discovery)
// and Prometheus (metrics.hpp). The pipeline's thread feeds the state through
// TelemetrySink; each exporter does its network work on threads of its own, so that a
// slow or absent server never delays decoding or recording.
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "pipeline.hpp"
#include "state/bus_state.hpp"

namespace rtuscope {

// One destination. Every call comes on the pipeline's thread with the state's mutex held,
// so an exporter reads the state freely here and must not block (no network I/O).
class Exporter {
  public:
    virtual ~Exporter() = default;
    virtual void begin(const BusState& /*state*/) {}
    // `record` has just gone into `state`; state.updated_slots() are the registers it set.
    virtual void record(const BusState& state, const Record& record) = 0;
    // Time passed with nothing on the line (a live run's idle tick): time-driven work.
    virtual void tick(const BusState& /*state*/, Nanos /*now*/) {}
    // The input ended or the run was stopped: what is queued is sent (within a bound).
    virtual void end(const BusState& /*state*/) {}
    // One line for the end of the run ("mqtt: 1203 messages published, 0 dropped");
    // empty when there is nothing to say.
    [[nodiscard]] virtual std::string summary() const { return {}; }
    // It could not do its job and was required to (--mqtt-required): the run exits 1.
    [[nodiscard]] virtual bool failed() const { return false; }
    // Messages it could not deliver so far (MQTT); nullopt for an exporter that drops none.
    [[nodiscard]] virtual std::optional<std::uint64_t> messages_dropped() const {
        return std::nullopt;
    }
};

// Feeds the records into the shared state and hands each to the exporters. The run's
// command prints their summaries once the run is over (a dashboard may hold the terminal
// until then).
class TelemetrySink final : public RecordSink {
  public:
    TelemetrySink(std::shared_ptr<SharedState> shared,
                  std::vector<std::unique_ptr<Exporter>> exporters)
        : shared_(std::move(shared)), exporters_(std::move(exporters)) {}
    void begin(const SessionInfo& session) override;
    void record(const Record& record) override;
    void idle(Nanos now) override;
    void end(const Totals& totals, const std::vector<std::string>& remarks) override;
    [[nodiscard]] const std::vector<std::unique_ptr<Exporter>>& exporters() const {
        return exporters_;
    }

  private:
    // The exporters' dropped messages into the state, for watch and the metrics.
    void count_dropped();
    std::shared_ptr<SharedState> shared_;
    std::vector<std::unique_ptr<Exporter>> exporters_;
};

// A topic level or an object id: every character outside [A-Za-z0-9_-] replaced by '_'
// ("ch1.s1" gives "ch1_s1": nothing is taken for a file's extension).
std::string safe_name(std::string_view text);

// "ttyUSB0" of "/dev/ttyUSB0", "field_log" of "logs/field log.txt": an input's base name
// made safe_name, "bus" when nothing is left.
std::string topic_name(std::string_view text);

}  // namespace rtuscope
