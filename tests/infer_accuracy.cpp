// How well `profiles infer` types the registers of devices whose profiles are known: the
// four bundled profiles' devices and the test-only energy meter, each polled for 120
// cycles (infer_support.hpp). Prints one line per device and the total: typed right,
// typed otherwise with the right type among the alternatives, wrong. Exits 1 if any is
// wrong.   build/tests/rtuscope_infer_accuracy
#include <fmt/format.h>

#include <cstdio>

#include "infer_support.hpp"
#include "input/sources.hpp"
#include "pipeline.hpp"

namespace {

using namespace rtuscope;

class PollMapSink final : public RecordSink {
  public:
    explicit PollMapSink(infer::PollMapBuilder& b) : builder_(b) {}
    void begin(const SessionInfo& /*session*/) override {}
    void record(const Record& r) override { builder_.add(r); }
    void end(const Totals& /*totals*/, const std::vector<std::string>& /*remarks*/) override {}

  private:
    infer::PollMapBuilder& builder_;
};

std::optional<infer::DeviceGuess> infer_capture(const std::string& text, std::uint8_t slave) {
    char path[] = "/tmp/rtuscope_infer_accuracy_XXXXXX";
    const int fd = mkstemp(path);
    if (fd < 0) return std::nullopt;
    std::FILE* f = fdopen(fd, "w");
    std::fwrite(text.data(), 1, text.size(), f);
    std::fclose(f);
    auto source = open_source(path, InputFormat::automatic);
    std::optional<infer::DeviceGuess> guess;
    if (source) {
        infer::PollMapBuilder builder;
        PollMapSink sink(builder);
        (void)run_pipeline(**source, PipelineOptions{}, sink);
        auto it = builder.slaves().find(slave);
        if (it != builder.slaves().end()) guess = infer::infer_device(it->second);
    }
    std::remove(path);
    return guess;
}

}  // namespace

int main() {
    std::vector<test::SimDevice> devices;
    std::uint8_t slave = 1;
    for (const Profile& profile : bundled_profiles()) devices.push_back(test::sim_device_of(profile, slave++));
    devices.push_back(test::energy_meter());
    test::InferScore total;
    fmt::print("{:<18} {:>9} {:>6} {:>10} {:>6}\n", "device", "registers", "right", "ambiguous", "wrong");
    for (const test::SimDevice& device : devices) {
        auto guess = infer_capture(test::sim_capture(device, 120), device.slave);
        test::InferScore score;
        if (guess) {
            score = test::score_guess(device, *guess);
        } else {
            score.wrong = static_cast<int>(device.registers.size());
        }
        fmt::print("{:<18} {:>9} {:>6} {:>10} {:>6}\n", device.name, device.registers.size(), score.right,
                   score.ambiguous_accepted, score.wrong);
        for (const std::string& w : score.wrong_names) fmt::print("  wrong: {}\n", w);
        total.right += score.right;
        total.ambiguous_accepted += score.ambiguous_accepted;
        total.wrong += score.wrong;
    }
    fmt::print("{:<18} {:>9} {:>6} {:>10} {:>6}\n", "total",
               total.right + total.ambiguous_accepted + total.wrong, total.right,
               total.ambiguous_accepted, total.wrong);
    return total.wrong == 0 ? 0 : 1;
}
