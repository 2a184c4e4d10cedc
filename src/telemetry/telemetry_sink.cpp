#include "telemetry/telemetry.hpp"

namespace rtuscope {

void TelemetrySink::begin(const SessionInfo& session) {
    const std::lock_guard lock(shared_->mutex);
    shared_->state.begin(session);
    for (auto& e : exporters_) e->begin(shared_->state);
}

void TelemetrySink::record(const Record& record) {
    const std::lock_guard lock(shared_->mutex);
    shared_->state.add(record);
    for (auto& e : exporters_) e->record(shared_->state, record);
    count_dropped();
}

void TelemetrySink::idle(Nanos now) {
    const std::lock_guard lock(shared_->mutex);
    for (auto& e : exporters_) e->tick(shared_->state, now);
    count_dropped();
}

void TelemetrySink::count_dropped() {
    std::optional<std::uint64_t> dropped;
    for (const auto& e : exporters_) {
        if (const auto n = e->messages_dropped()) dropped = dropped.value_or(0) + *n;
    }
    shared_->state.set_messages_dropped(dropped);
}

void TelemetrySink::end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) {
    const std::lock_guard lock(shared_->mutex);
    shared_->state.refresh();
    for (auto& e : exporters_) e->end(shared_->state);
}

std::string topic_name(std::string_view text) {
    // The base name: what follows the last '/', without a file's extension.
    if (const auto slash = text.rfind('/'); slash != std::string_view::npos) {
        text.remove_prefix(slash + 1);
    }
    if (const auto dot = text.rfind('.'); dot != std::string_view::npos && dot > 0) {
        text = text.substr(0, dot);
    }
    return text.empty() ? std::string("bus") : safe_name(text);
}

std::string safe_name(std::string_view text) {
    std::string out(text);
    for (char& c : out) {
        const bool keep = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') ||
                          (c >= '0' && c <= '9') || c == '_' || c == '-';
        if (!keep) c = '_';
    }
    return out;
}

}  // namespace rtuscope
