// `profiles infer`: captures of devices whose registers are known (infer_support.hpp),
// inferred back; the types found must be the devices' own, or among the alternatives the
// draft names when the values cannot tell them apart.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>

#include "infer/poll_map.hpp"
#include "infer/profile_writer.hpp"
#include "infer/scoring.hpp"
#include "infer_support.hpp"
#include "input/readers.hpp"
#include "input/sources.hpp"
#include "pipeline.hpp"
#include "support.hpp"

namespace rtuscope::test {
namespace {

class PollMapSink final : public RecordSink {
  public:
    explicit PollMapSink(infer::PollMapBuilder& b) : builder(b) {}
    void begin(const SessionInfo&) override {}
    void record(const Record& r) override { builder.add(r); }
    void end(const Totals&, const std::vector<std::string>&) override {}
    infer::PollMapBuilder& builder;
};

std::map<std::uint8_t, infer::DeviceGuess> infer_text(const std::string& text) {
    TempDir dir;
    const std::string path = dir.write("bus.rtucap", text);
    auto source = open_source(path, InputFormat::automatic);
    EXPECT_TRUE(source.ok());
    std::map<std::uint8_t, infer::DeviceGuess> out;
    if (!source.ok()) return out;
    infer::PollMapBuilder builder;
    PollMapSink sink(builder);
    (void)run_pipeline(**source, PipelineOptions{}, sink);
    for (const auto& [slave, traffic] : builder.slaves()) out[slave] = infer::infer_device(traffic);
    return out;
}

const infer::RegisterGuess* at(const infer::DeviceGuess& d, infer::Table table, std::uint16_t address) {
    for (const auto& g : d.registers) {
        if (g.table == table && g.address == address) return &g;
    }
    return nullptr;
}

TEST(Infer, EnergyMeterTypesAndWordOrders) {
    const SimDevice meter = energy_meter();
    auto guesses = infer_text(sim_capture(meter, 120));
    ASSERT_TRUE(guesses.contains(7));
    const infer::DeviceGuess& d = guesses[7];
    for (std::uint16_t address : {std::uint16_t{0x0000}, std::uint16_t{0x0002}, std::uint16_t{0x0004}}) {
        const auto* g = at(d, infer::Table::input, address);
        ASSERT_NE(g, nullptr) << address;
        EXPECT_EQ(g->type, ValueType::f32) << address;
        EXPECT_EQ(g->word_order, WordOrder::cdab) << address;
    }
    const auto* abcd = at(d, infer::Table::holding, 0x0100);
    ASSERT_NE(abcd, nullptr);
    EXPECT_EQ(abcd->type, ValueType::u32);
    EXPECT_EQ(abcd->word_order, WordOrder::abcd);
    EXPECT_TRUE(abcd->counter);
    const auto* cdab = at(d, infer::Table::holding, 0x0102);
    ASSERT_NE(cdab, nullptr);
    EXPECT_EQ(cdab->type, ValueType::u32);
    EXPECT_EQ(cdab->word_order, WordOrder::cdab);
    for (std::uint16_t address : {std::uint16_t{0x0200}, std::uint16_t{0x0201}}) {
        const auto* g = at(d, infer::Table::holding, address);
        ASSERT_NE(g, nullptr);
        EXPECT_EQ(g->type, ValueType::i16) << address;
    }
    const auto* status = at(d, infer::Table::holding, 0x0202);
    ASSERT_NE(status, nullptr);
    EXPECT_EQ(status->type, ValueType::bits);
    EXPECT_EQ(status->labels, (std::vector<std::uint16_t>{0, 3}));
    const auto* mode = at(d, infer::Table::holding, 0x0203);
    ASSERT_NE(mode, nullptr);
    EXPECT_EQ(mode->type, ValueType::enumeration);
    EXPECT_EQ(mode->labels, (std::vector<std::uint16_t>{0, 1, 2}));
    EXPECT_EQ(mode->access, Access::read_write);
    const auto* constant = at(d, infer::Table::holding, 0x0204);
    ASSERT_NE(constant, nullptr);
    EXPECT_TRUE(constant->constant);
    // 50.0 Hz as a constant f32: its words are constants, the f32 reading an alternative.
    const auto* frequency = at(d, infer::Table::input, 0x0006);
    ASSERT_NE(frequency, nullptr);
    EXPECT_TRUE(frequency->constant);
    EXPECT_TRUE(frequency->accepts(ValueType::f32, WordOrder::cdab));
    const InferScore score = score_guess(meter, d);
    EXPECT_EQ(score.wrong, 0) << ::testing::PrintToString(score.wrong_names);
}

TEST(Infer, PollMapHasBlocksAndPeriods) {
    auto guesses = infer_text(sim_capture(energy_meter(), 30, 2.0));
    const infer::DeviceGuess& d = guesses[7];
    ASSERT_GE(d.poll_map.size(), 3U);
    EXPECT_EQ(d.poll_map[0], "FC04 input 0x0000-0x0007 (8 registers): 30 polls, every 2 s (median)");
    EXPECT_TRUE(std::any_of(d.poll_map.begin(), d.poll_map.end(), [](const std::string& line) {
        return line == "FC06 holding 0x0203: written 3 times, values 0, 1";
    })) << ::testing::PrintToString(d.poll_map);
}

TEST(Infer, BundledProfilesInferBack) {
    std::uint8_t slave = 1;
    for (const Profile& profile : bundled_profiles()) {
        const SimDevice device = sim_device_of(profile, slave++);
        auto guesses = infer_text(sim_capture(device, 120));
        ASSERT_TRUE(guesses.contains(device.slave)) << profile.name;
        const InferScore score = score_guess(device, guesses[device.slave]);
        EXPECT_EQ(score.wrong, 0) << profile.name << ": " << ::testing::PrintToString(score.wrong_names);
        EXPECT_GT(score.right + score.ambiguous_accepted, 0) << profile.name;
    }
}

TEST(Infer, NoRegisterThatWasNotOnTheBus) {
    const SimDevice meter = energy_meter();
    auto guesses = infer_text(sim_capture(meter, 40));
    for (const infer::RegisterGuess& g : guesses[7].registers) {
        const bool polled = std::any_of(meter.blocks.begin(), meter.blocks.end(), [&](const SimBlock& b) {
            return sim_infer_table(sim_table_of(b.function)) == g.table && g.address >= b.start &&
                   g.address + g.length <= b.start + b.count;
        });
        EXPECT_TRUE(polled) << infer::table_name(g.table) << " " << g.address;
    }
}

TEST(Infer, DraftLoadsAsAProfile) {
    auto guesses = infer_text(sim_capture(energy_meter(), 60));
    const std::string toml = infer::write_profile(guesses[7], "meter.rtucap");
    const ProfileLoad load = load_profile_text(toml, "draft.toml");
    ASSERT_TRUE(load.profile) << toml;
    EXPECT_TRUE(load.problems.empty());
    EXPECT_EQ(load.profile->name, "slave-7");
    EXPECT_EQ(load.profile->registers.size(), guesses[7].registers.size());
    const Register* voltage = load.profile->register_at("input", 0x0000);
    ASSERT_NE(voltage, nullptr);
    EXPECT_EQ(voltage->name, "reg_0x0000");
    EXPECT_EQ(voltage->type, ValueType::f32);
    EXPECT_EQ(voltage->word_order, WordOrder::cdab);
    EXPECT_NE(toml.find("# f32 cdab, confidence high"), std::string::npos);
}

TEST(Infer, GarbageExceptionsAndWritesOnlyGiveNoReads) {
    std::string garbage = "# rtuscope capture v1\n# serial 9600 8N1\n";
    Chunk chunk;
    chunk.time = 1'000'000'000;
    for (int i = 0; i < 200; ++i) chunk.bytes.push_back(static_cast<std::uint8_t>(i * 37 + 11));
    garbage += capture_line(chunk);
    for (const auto& [slave, d] : infer_text(garbage)) EXPECT_EQ(d.answered_reads, 0U);

    std::string exceptions = "# rtuscope capture v1\n# serial 9600 8N1\n";
    for (int i = 0; i < 5; ++i) {
        Chunk request;
        request.time = (2 * i + 1) * 100'000'000LL;
        request.bytes = with_crc({1, 3, 0, 0, 0, 2});
        exceptions += capture_line(request);
        Chunk answer;
        answer.time = request.time + 20'000'000;
        answer.bytes = with_crc({1, 0x83, 2});
        exceptions += capture_line(answer);
    }
    auto e = infer_text(exceptions);
    ASSERT_TRUE(e.contains(1));
    EXPECT_EQ(e[1].answered_reads, 0U);
    EXPECT_TRUE(e[1].registers.empty());

    SimDevice writer = energy_meter();
    writer.blocks.clear();
    auto w = infer_text(sim_capture(writer, 30));
    ASSERT_TRUE(w.contains(7));
    EXPECT_EQ(w[7].answered_reads, 0U);
    const auto* mode = at(w[7], infer::Table::holding, 0x0203);
    ASSERT_NE(mode, nullptr);
    EXPECT_EQ(mode->access, Access::write);
}

}  // namespace
}  // namespace rtuscope::test
