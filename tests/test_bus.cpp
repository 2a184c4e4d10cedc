// The bus map and the protocol rules a device's profile brings: its own function codes
// (length, echo answers), its broadcast address, silence instead of exceptions.
#include <gtest/gtest.h>

#include "decode/pdu_decoders.hpp"
#include "decode/record_decoder.hpp"
#include "pipeline.hpp"
#include "profiles/bus.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using test::Bytes;
using test::Line;
using test::with_crc;

// A device like the ZB-UVI485: FC04 and FC05 are its own writes answered by an echo,
// it listens on 255 for broadcasts and never answers with an exception.
Profile uv_like() {
    Profile p;
    p.name = "uv-test";
    p.broadcast = 255;
    p.exception_answers = false;
    FunctionSpec set_coefficient = own_function(0x04);
    set_coefficient.name = "Set correction coefficient";
    set_coefficient.request_length = LengthRule::fixed(8);
    set_coefficient.answer = Answer::echo;
    set_coefficient.decode_request = set_coefficient.decode_response =
        device_layout_decoder("address_value");
    set_coefficient.device_table = "eeprom";
    FunctionSpec fire_and_forget = own_function(0x42);
    fire_and_forget.name = "Blink";
    fire_and_forget.request_length = LengthRule::fixed(5);
    fire_and_forget.answer = Answer::none;
    p.functions = {set_coefficient, fire_and_forget};
    Register intensity;
    intensity.name = "uv_intensity";
    intensity.scale = 0.1;
    intensity.unit = "uW/cm2";
    Register coefficient;
    coefficient.table = "eeprom";
    coefficient.address = 0x0015;
    coefficient.name = "correction_coefficient";
    coefficient.scale = 0.1;
    coefficient.access = Access::write;
    p.registers = {coefficient, intensity};
    return p;
}

struct BusHarness {
    BusHarness() {
        bus.add_profile(uv_like());
        EXPECT_TRUE(bus.assign(1, "uv-test"));
    }
    std::vector<Record> run(const std::vector<Chunk>& chunks) {
        BusRules rules(bus);
        std::vector<Record> records;
        Transactions transactions({kNanosPerSecond, &rules}, [&](Record&& r) {
            decode_record(r, rules, &bus);
            records.push_back(std::move(r));
        });
        FramerOptions o;
        o.rules = &rules;
        o.expectation = &transactions;
        Framer framer(o, [&](Frame& f) { transactions.push(f); });
        for (const Chunk& c : chunks) framer.push(c);
        framer.finish();
        transactions.finish();
        return records;
    }
    Bus bus;
};

TEST(Bus, OwnFunctionCodeIsFramedAndPairedAsAnEcho) {
    // Standard Modbus would read 01 04 00 15 00 12 as "Read Input Registers 0x0015 x18"
    // and expect a 41-byte answer; the profile says an 8-byte request and its echo.
    const Bytes set = with_crc({0x01, 0x04, 0x00, 0x15, 0x00, 0x12});
    Line line;
    line.silence(10).send_per_byte(set).silence(5).send_per_byte(set);
    BusHarness h;
    const auto r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[0].kind, Kind::request);
    EXPECT_EQ(r[1].kind, Kind::response);
    EXPECT_EQ(r[1].request_number, 1U);
    EXPECT_EQ(r[0].decoded.function_name, "Set correction coefficient");
    EXPECT_EQ(r[0].decoded.summary, "0x0015 = 0x0012");
    ASSERT_EQ(r[0].decoded.blocks.size(), 1U);
    EXPECT_EQ(r[0].decoded.blocks[0].custom_table, "eeprom");
    EXPECT_EQ(r[0].profile->name, "uv-test");
}

TEST(Bus, OwnBroadcastAddressExpectsNoAnswer) {
    const Bytes broadcast = with_crc({0xFF, 0x04, 0x00, 0x15, 0x00, 0x12});
    BusHarness h;
    Line line;
    line.silence(10).send_per_byte(broadcast).silence(200);
    const auto r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 1U);
    EXPECT_EQ(r[0].kind, Kind::broadcast);
    EXPECT_FALSE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[0].decoded.function_name, "Set correction coefficient");
}

TEST(Bus, AddressZeroIsADeviceWhenItsProfileBroadcastsElsewhere) {
    const Bytes read = with_crc({0x00, 0x03, 0x00, 0x00, 0x00, 0x01});
    const Bytes answer = with_crc({0x00, 0x03, 0x02, 0x18, 0x18});
    Line line;
    line.silence(10).send_per_byte(read).silence(5).send_per_byte(answer);
    BusHarness h;
    ASSERT_TRUE(h.bus.assign(0, "uv-test"));
    const auto r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 2U);
    EXPECT_EQ(r[0].kind, Kind::request);
    EXPECT_EQ(r[1].kind, Kind::response);
    EXPECT_EQ(r[1].request_number, 1U);
    // Without that device on 0, address 0 is the standard broadcast.
    BusHarness standard;
    const auto s = standard.run(line.chunks());
    ASSERT_GE(s.size(), 1U);
    EXPECT_EQ(s[0].kind, Kind::broadcast);
}

TEST(Bus, SilenceInsteadOfExceptionsIsSaid) {
    const Bytes read = with_crc({0x01, 0x03, 0x01, 0x00, 0x00, 0x01});
    const Bytes exception = with_crc({0x01, 0x83, 0x02});
    BusHarness h;
    Line line;
    line.silence(10).send_per_byte(read).silence_ms(1500).send_per_byte(read).silence(5);
    line.send_per_byte(exception);
    const auto r = h.run(line.chunks());
    ASSERT_EQ(r.size(), 3U);
    ASSERT_TRUE(r[0].notes.has(note_id::no_answer));
    EXPECT_EQ(r[0].notes.back().text,
              "no answer within 1 s (this device answers errors with silence)");
    EXPECT_EQ(r[2].kind, Kind::exception);
    EXPECT_TRUE(r[2].notes.has(note_id::unexpected_exception));
}

TEST(Bus, FunctionThatIsNeverAnsweredIsNotAwaited) {
    const Bytes blink = with_crc({0x01, 0x42, 0x07});
    BusHarness h;
    const auto r = h.run({Chunk{kNoTime, "", blink, 0, {}}});
    ASSERT_EQ(r.size(), 1U);
    EXPECT_EQ(r[0].kind, Kind::request);
    EXPECT_FALSE(r[0].notes.has(note_id::no_answer));
}

TEST(Bus, OtherSlavesKeepTheStandardRules) {
    const Bytes read_inputs = with_crc({0x02, 0x04, 0x00, 0x15, 0x00, 0x02});
    BusHarness h;
    const auto r = h.run({Chunk{kNoTime, "", read_inputs, 0, {}}});
    ASSERT_EQ(r.size(), 1U);
    EXPECT_EQ(r[0].decoded.function_name, "Read Input Registers");
    EXPECT_EQ(r[0].profile, nullptr);
}

TEST(Bus, RequestOverTheDevicesRegisterLimitIsNoted) {
    BusHarness h;
    Profile small = uv_like();
    small.name = "small";
    small.max_registers = 100;
    h.bus.add_profile(small);
    ASSERT_TRUE(h.bus.assign(2, "small"));
    const auto r =
        h.run({Chunk{kNoTime, "", with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x65}), 0, {}},
               Chunk{kNoTime, "", with_crc({0x02, 0x03, 0x00, 0x00, 0x00, 0x64}), 0, {}}});
    ASSERT_EQ(r.size(), 2U);
    ASSERT_TRUE(r[0].notes.has(note_id::over_device_limit));
    EXPECT_EQ(r[0].notes.back().text, "101 registers asked, small allows at most 100");
    EXPECT_FALSE(r[1].notes.has(note_id::over_device_limit));
}

TEST(Bus, ReservedAddressIsFlaggedUnlessTheProfileUsesIt) {
    const Bytes to_250 = with_crc({0xFA, 0x03, 0x00, 0x06, 0x00, 0x01});
    const Bytes to_255 = with_crc({0xFF, 0x04, 0x00, 0x15, 0x00, 0x12});
    {
        BusHarness standard_only;  // nothing on 250
        const auto r = standard_only.run({Chunk{kNoTime, "", to_250, 0, {}}});
        ASSERT_EQ(r.size(), 1U);
        ASSERT_TRUE(r[0].notes.has(note_id::reserved_address));
        EXPECT_EQ(r[0].notes.back().text, "slave address 250 is reserved (248-255)");
    }
    BusHarness h;  // uv-test on 1 broadcasts on 255
    Profile wide = uv_like();
    wide.name = "wide";
    wide.broadcast.reset();
    wide.last_address = 250;
    h.bus.add_profile(wide);
    ASSERT_TRUE(h.bus.assign(250, "wide"));
    const auto r = h.run({Chunk{kNoTime, "", to_250, 0, {}}, Chunk{kNoTime, "", to_255, 0, {}}});
    ASSERT_EQ(r.size(), 2U);
    EXPECT_FALSE(r[0].notes.has(note_id::reserved_address));
    EXPECT_FALSE(r[1].notes.has(note_id::reserved_address));
}

TEST(Bus, DeviceOption) {
    Bus bus;
    bus.add_profile(uv_like());
    EXPECT_TRUE(assign_device_option(bus, "7=uv-test"));
    EXPECT_TRUE(assign_device_option(bus, "0x10=uv-test"));
    EXPECT_EQ(bus.profile_for(7)->name, "uv-test");
    EXPECT_EQ(bus.profile_for(16)->name, "uv-test");
    EXPECT_EQ(bus.profile_for(8), nullptr);
    const Status unknown = assign_device_option(bus, "3=nosuch");
    ASSERT_FALSE(unknown);
    EXPECT_NE(unknown.error().message.find("unknown profile \"nosuch\""), std::string::npos);
    EXPECT_FALSE(assign_device_option(bus, "300=uv-test"));
    EXPECT_FALSE(assign_device_option(bus, "uv-test"));
}

// The bundled profiles are parsed on first use; a user's profile of the same name must
// still replace one, whether it comes before or after the first lookup, and bring its
// broadcast address with it.
TEST(Bus, UsersProfileReplacesTheBundledOneOfTheSameName) {
    Bus before_lookup;
    Profile own = uv_like();
    own.name = "pdu485";
    before_lookup.add_profile(own);
    ASSERT_NE(before_lookup.find_profile("pdu485"), nullptr);
    EXPECT_EQ(before_lookup.find_profile("pdu485")->broadcast, 255);
    EXPECT_NE(before_lookup.find_profile("zyi-relay"), nullptr);
    EXPECT_EQ(before_lookup.profiles().size(), 4U);

    Bus after_assign;
    ASSERT_TRUE(assign_device_option(after_assign, "3=pdu485"));
    const Profile* slot = after_assign.profile_for(3);
    EXPECT_NE(slot->broadcast, 255);
    EXPECT_EQ(after_assign.owner(255), nullptr);
    after_assign.add_profile(own);
    EXPECT_EQ(after_assign.profile_for(3), slot);  // the same slot, now the user's profile
    EXPECT_EQ(after_assign.profile_for(3)->broadcast, 255);
    EXPECT_EQ(after_assign.owner(255), slot);  // its broadcast address is now the device's
    EXPECT_EQ(after_assign.profiles().size(), 4U);
}

TEST(Bus, BusFileIsAppliedWhole) {
    const test::TempDir dir;
    const std::string path =
        dir.write("bus.toml",
                  "line = \"9600 8E1\"\n\n[[device]]\naddress = 1\nprofile = \"uv-test\"\n\n"
                  "[[device]]\naddress = 0x10\nprofile = \"pdu485\"\n");
    Bus bus;
    bus.add_profile(uv_like());
    EXPECT_TRUE(load_bus_file(bus, path).empty());
    EXPECT_EQ(bus.profile_for(1)->name, "uv-test");
    EXPECT_EQ(bus.profile_for(16)->name, "pdu485");
    ASSERT_TRUE(bus.line());
    EXPECT_EQ(bus.line()->format(), "8E1");
}

// Every mistake of a bus file, in file order, and nothing of the file applied.
TEST(Bus, BusFileReportsEveryMistake) {
    const test::TempDir dir;
    const std::string path =
        dir.write("bus.toml",
                  "line = \"9600 8Q1\"\nspeed = 9600\n\n[[device]]\naddress = 1\n"
                  "profile = \"uv-test\"\n\n[[device]]\naddress = 256\nprofile = 3\n\n"
                  "[[device]]\naddress = 2\nprofile = \"nosuch\"\nport = 1\n\n"
                  "[[device]]\naddress = 4\n");
    Bus bus;
    bus.add_profile(uv_like());
    std::string all;
    for (const ProfileProblem& p : load_bus_file(bus, path)) {
        all += p.to_string().substr(dir.path().size() + 1) + "\n";
    }
    EXPECT_EQ(all,
              "bus.toml:1:8: bad line format \"8Q1\" (expected data bits 5-8, parity N/E/O, stop "
              "bits 1-2, e.g. 8N1 or 8E1)\n"
              "bus.toml:2:1: unknown key \"speed\" (a bus file has line and [[device]])\n"
              "bus.toml:9:11: address must be a number from 0 to 255\n"
              "bus.toml:10:11: profile must be a string\n"
              "bus.toml:14:11: unknown profile \"nosuch\" (known: pdu485, sensor-analyser, "
              "uv-test, zb-uvi485, zyi-relay)\n"
              "bus.toml:15:1: unknown key \"port\" in [[device]]\n"
              "bus.toml:17:1: [[device]] needs address and profile\n");
    EXPECT_EQ(bus.profile_for(1), nullptr);
    EXPECT_FALSE(bus.line());
}

TEST(Bus, BusFileSyntaxErrorIsInPlainWords) {
    const auto load = read_bus_text(Bus(), "[[device]\naddress = 1\n", "bus.toml");
    EXPECT_FALSE(load.bus);
    ASSERT_EQ(load.problems.size(), 1U);
    EXPECT_EQ(load.problems[0].to_string(),
              "bus.toml:1:1: the table header [[device] is not closed: write [[device]]");
}

TEST(Bus, ProfileGivenAsBusFileIsSaidSo) {
    const auto load = read_bus_text(Bus(), "[device]\nname = \"m\"\n", "m.toml");
    ASSERT_EQ(load.problems.size(), 1U);
    EXPECT_EQ(load.problems[0].to_string(),
              "m.toml: is a device profile ([device]), not a bus file: give it with --profile");
}

TEST(Bus, FileKindIsToldByContent) {
    EXPECT_EQ(toml_file_kind("[device]\nname = \"m\"\n"), TomlFileKind::profile);
    EXPECT_EQ(toml_file_kind("[[register]]\naddress = 1\n"), TomlFileKind::profile);
    EXPECT_EQ(toml_file_kind("[[device]]\naddress = 1\nprofile = \"m\"\n"), TomlFileKind::bus);
    EXPECT_EQ(toml_file_kind("line = \"9600 8N1\"\n"), TomlFileKind::bus);
    EXPECT_EQ(toml_file_kind("[meter]\nname = \"m\"\n"), TomlFileKind::neither);
    EXPECT_EQ(toml_file_kind(""), TomlFileKind::neither);
    EXPECT_EQ(toml_file_kind("[[device]\n"), TomlFileKind::profile);  // the loader says why
}

}  // namespace
}  // namespace rtuscope
