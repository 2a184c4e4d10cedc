// Trigger expressions (--trigger): each term, AND within an expression, OR across
// several, lists inside terms, every parse error with its column, and the events found
// in the bundled device captures decoded with their profiles.
#include "output/trigger.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "input/sources.hpp"
#include "pipeline.hpp"
#include "profiles/values.hpp"
#include "support.hpp"

namespace rtuscope {
namespace {

using test::CollectingSink;

// A bus with pdu485 on slaves 1 and 250, as captures/devices/pdu485.bus.toml has it.
class TriggerTest : public ::testing::Test {
  protected:
    void SetUp() override {
        ASSERT_TRUE(bus_.assign(1, "pdu485"));
        ASSERT_TRUE(bus_.assign(250, "pdu485"));
        context_ = trigger_context(&bus_);
    }

    Trigger parse(const std::string& expr) const {
        auto trigger = parse_trigger(expr, context_);
        EXPECT_TRUE(trigger) << expr << ": " << trigger.error().message;
        return trigger ? *trigger : Trigger{};
    }

    // The error's message, checking that the column it names is the Error's.
    std::string error(const std::string& expr) const {
        auto trigger = parse_trigger(expr, context_);
        if (trigger) {
            ADD_FAILURE() << expr << " parsed";
            return {};
        }
        const std::string prefix = "column " + std::to_string(trigger.error().column) + ": ";
        EXPECT_EQ(trigger.error().message.rfind(prefix, 0), 0U) << trigger.error().message;
        return trigger.error().message;
    }

    Bus bus_;
    TriggerContext context_;
};

// A frame of `slave` and `function` (a CRC that checks unless said otherwise).
Record frame_record(Kind kind, std::uint8_t slave, std::uint8_t function,
                    CrcStatus crc = CrcStatus::ok) {
    Record r;
    r.kind = kind;
    r.frame.cls = crc == CrcStatus::bad ? RecordClass::invalid : RecordClass::frame;
    r.frame.bytes = {slave, function, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00};
    r.frame.crc.status = crc;
    return r;
}

Record noise_record() {
    Record r;
    r.kind = Kind::noise;
    r.frame.bytes = {0x01, 0x03};
    return r;
}

// An answer of slave 1 carrying one register value.
Record value_record(const std::string& name, const std::string& value) {
    Record r = frame_record(Kind::response, 1, 3);
    DecodedValue& v = r.values.add();
    v.name = name;
    v.value = value;
    return r;
}

TEST_F(TriggerTest, KindMatchesTheListedKindsAndFlagged) {
    const Trigger t = parse("kind=request,exception");
    EXPECT_TRUE(t.matches(frame_record(Kind::request, 1, 3)));
    EXPECT_TRUE(t.matches(frame_record(Kind::exception, 1, 0x83)));
    EXPECT_FALSE(t.matches(frame_record(Kind::response, 1, 3)));

    const Trigger flagged = parse("kind=flagged");
    Record noted = frame_record(Kind::response, 1, 3);
    EXPECT_FALSE(flagged.matches(noted));
    noted.notes.add(note_id::duplicate_answer, "second answer");
    EXPECT_TRUE(flagged.matches(noted));
}

TEST_F(TriggerTest, SlaveMatchesListsAndRangesButNoNoise) {
    const Trigger t = parse("slave=1,3,10-20,0xFA");
    for (const unsigned slave : {1U, 3U, 10U, 15U, 20U, 250U}) {
        EXPECT_TRUE(t.matches(frame_record(Kind::request, static_cast<std::uint8_t>(slave), 3)))
            << slave;
    }
    for (const unsigned slave : {2U, 9U, 21U, 249U}) {
        EXPECT_FALSE(t.matches(frame_record(Kind::request, static_cast<std::uint8_t>(slave), 3)))
            << slave;
    }
    EXPECT_FALSE(t.matches(noise_record()));  // its first byte is no address
}

TEST_F(TriggerTest, FunctionMatchesExceptionsAsTheirFunction) {
    const Trigger t = parse("function=3,0x10");
    EXPECT_TRUE(t.matches(frame_record(Kind::request, 1, 3)));
    EXPECT_TRUE(t.matches(frame_record(Kind::exception, 1, 0x83)));
    EXPECT_TRUE(t.matches(frame_record(Kind::request, 1, 0x10)));
    EXPECT_FALSE(t.matches(frame_record(Kind::request, 1, 4)));
}

TEST_F(TriggerTest, FlagMatchesRecordAndValueNotes) {
    const Trigger t = parse("flag=txn.no_answer,value.out_of_range");
    Record request = frame_record(Kind::request, 1, 3);
    EXPECT_FALSE(t.matches(request));
    request.notes.add(note_id::unsolicited, "no request");
    EXPECT_FALSE(t.matches(request));
    request.notes.add(note_id::no_answer, "no answer");
    EXPECT_TRUE(t.matches(request));

    Record answer = value_record("voltage", "350.0");
    EXPECT_FALSE(t.matches(answer));
    answer.values[0].notes.add(note_id::value_out_of_range, "outside 0.0..300.0 V");
    EXPECT_TRUE(t.matches(answer));
}

TEST_F(TriggerTest, CrcMatchesTheCsvWords) {
    const Trigger bad = parse("crc=bad");
    EXPECT_TRUE(bad.matches(frame_record(Kind::invalid, 1, 3, CrcStatus::bad)));
    EXPECT_FALSE(bad.matches(frame_record(Kind::request, 1, 3, CrcStatus::ok)));
    EXPECT_FALSE(bad.matches(frame_record(Kind::request, 1, 3, CrcStatus::swapped)));
    EXPECT_FALSE(bad.matches(noise_record()));

    const Trigger either = parse("crc=bad,swapped");
    EXPECT_TRUE(either.matches(frame_record(Kind::request, 1, 3, CrcStatus::swapped)));
    EXPECT_TRUE(either.matches(frame_record(Kind::invalid, 1, 3, CrcStatus::bad)));
    EXPECT_FALSE(either.matches(frame_record(Kind::request, 1, 3, CrcStatus::ok)));
}

TEST_F(TriggerTest, ComparisonsOfNumbersAsShown) {
    const Trigger above = parse("voltage>250");
    EXPECT_TRUE(above.matches(value_record("voltage", "250.1")));
    EXPECT_FALSE(above.matches(value_record("voltage", "250.0")));
    EXPECT_FALSE(above.matches(value_record("voltage", "12.5")));
    EXPECT_FALSE(above.matches(value_record("current", "300.0")));  // another register
    EXPECT_FALSE(above.matches(value_record("voltage", "")));       // half a value: none
    EXPECT_FALSE(above.matches(frame_record(Kind::request, 1, 3)));  // no values at all

    EXPECT_TRUE(parse("voltage>=250").matches(value_record("voltage", "250.0")));
    EXPECT_FALSE(parse("voltage>=250").matches(value_record("voltage", "249.9")));
    EXPECT_TRUE(parse("voltage<0").matches(value_record("voltage", "-0.5")));
    EXPECT_FALSE(parse("voltage<0").matches(value_record("voltage", "0.0")));
    EXPECT_TRUE(parse("voltage<=-0.5").matches(value_record("voltage", "-0.5")));
    EXPECT_FALSE(parse("voltage<=-0.5").matches(value_record("voltage", "-0.4")));
}

TEST_F(TriggerTest, EqualityOfNumbersAndLabels) {
    const Trigger numbers = parse("voltage=220,230.5");
    EXPECT_TRUE(numbers.matches(value_record("voltage", "220.0")));
    EXPECT_TRUE(numbers.matches(value_record("voltage", "230.5")));
    EXPECT_FALSE(numbers.matches(value_record("voltage", "220.1")));

    const Trigger label = parse("display_mode=cycling display");
    EXPECT_TRUE(label.matches(value_record("display_mode", "cycling display")));
    EXPECT_FALSE(label.matches(value_record("display_mode", "fixed display")));
    // An enum value with no label is shown as its number.
    EXPECT_TRUE(parse("display_mode=7").matches(value_record("display_mode", "7")));
    // The meaning of a special write is a label too.
    EXPECT_TRUE(parse("energy=clear the energy counter")
                    .matches(value_record("energy", "clear the energy counter")));
}

TEST_F(TriggerTest, AllTermsMustHold) {
    const Trigger t = parse("slave=3,crc=bad");
    EXPECT_TRUE(t.matches(frame_record(Kind::invalid, 3, 3, CrcStatus::bad)));
    EXPECT_FALSE(t.matches(frame_record(Kind::invalid, 4, 3, CrcStatus::bad)));
    EXPECT_FALSE(t.matches(frame_record(Kind::request, 3, 3, CrcStatus::ok)));

    const Trigger value = parse("slave=250,voltage>250");
    Record from_250 = value_record("voltage", "260.0");
    EXPECT_FALSE(value.matches(from_250));  // slave 1
    from_250.frame.bytes[0] = 250;
    EXPECT_TRUE(value.matches(from_250));
}

TEST_F(TriggerTest, AnyOfSeveralFiresTheFirstThatMatches) {
    const std::vector<Trigger> triggers = {parse("kind=exception"), parse("crc=bad"),
                                           parse("slave=1-10")};
    EXPECT_EQ(first_firing(triggers, frame_record(Kind::exception, 20, 0x83)), 0U);
    EXPECT_EQ(first_firing(triggers, frame_record(Kind::invalid, 20, 3, CrcStatus::bad)), 1U);
    EXPECT_EQ(first_firing(triggers, frame_record(Kind::exception, 5, 0x83)), 0U);
    EXPECT_EQ(first_firing(triggers, frame_record(Kind::request, 5, 3)), 2U);
    EXPECT_EQ(first_firing(triggers, frame_record(Kind::request, 20, 3)), std::nullopt);
    EXPECT_EQ(first_firing({}, frame_record(Kind::request, 20, 3)), std::nullopt);
}

// Commas inside lists and between terms: a comma before NAME= starts a term.
TEST_F(TriggerTest, ListsWithCommasInsideTerms) {
    const Trigger t = parse("slave=1,3,crc=bad,swapped,kind=invalid,request");
    ASSERT_EQ(t.terms.size(), 3U);
    EXPECT_TRUE(t.matches(frame_record(Kind::invalid, 3, 3, CrcStatus::bad)));
    EXPECT_TRUE(t.matches(frame_record(Kind::request, 1, 3, CrcStatus::swapped)));
    EXPECT_FALSE(t.matches(frame_record(Kind::request, 2, 3, CrcStatus::swapped)));
    EXPECT_FALSE(t.matches(frame_record(Kind::response, 1, 3, CrcStatus::swapped)));
    EXPECT_FALSE(t.matches(frame_record(Kind::request, 1, 3, CrcStatus::ok)));
}

TEST_F(TriggerTest, SpacesAroundTermsAndOperators) {
    const Trigger t = parse(" slave = 1, 3 , voltage > 250 ");
    ASSERT_EQ(t.terms.size(), 2U);
    Record r = value_record("voltage", "251.0");
    EXPECT_TRUE(t.matches(r));
    r.frame.bytes[0] = 2;
    EXPECT_FALSE(t.matches(r));
}

TEST_F(TriggerTest, EveryErrorNamesItsColumn) {
    struct Case {
        std::string expr;
        std::string message;
    };
    const std::vector<Case> cases = {
        {"", "column 1: empty expression"},
        {"   ", "column 1: empty expression"},
        {"crc=bad,slvae=3", "column 9: unknown term \"slvae\" (did you mean slave?)"},
        {"voltge>250", "column 1: unknown term \"voltge\" (did you mean voltage"},
        {"frobnicate=1", "column 1: unknown term \"frobnicate\" (kind, slave, function, flag, "
                         "crc, or a register of pdu485)"},
        {"hello", "column 1: \"hello\" is no term"},
        {"crc", "column 1: \"crc\" needs a value (crc=...)"},
        {"slave=3,crc", "column 9: \"crc\" needs a value (crc=...)"},
        {"slave=1,x", "column 9: bad list \"x\""},
        {"slave=1,300", "column 9: bad list \"300\""},
        {"function=3-1", "column 10: bad list \"3-1\""},
        {"kind=request,responses", "column 14: unknown kind \"responses\""},
        {"flag=txn.no_anwser", "column 6: unknown note id \"txn.no_anwser\" (did you mean "
                               "txn.no_answer?)"},
        {"flag=frame.noise", "column 6: unknown note id \"frame.noise\""},
        {"crc=wrong", "column 5: unknown CRC state \"wrong\" (ok, bad, swapped)"},
        {"slave=1,,2", "column 9: nothing between two commas"},
        {"crc=bad,", "column 9: nothing after the comma"},
        {",crc=bad", "column 1: nothing before the comma"},
        {"slave=", "column 7: nothing after \"slave=\""},
        {"=3", "column 1: a term starts with a name"},
        {"slave>3", "column 6: slave takes =, not > (slave=1,3,10-20)"},
        {"voltage>abc", "column 9: \"abc\" is not a number (voltage>250)"},
        {"voltage>0x10", "column 9: \"0x10\" is not a number"},
        {"voltage<250,260", "column 13: voltage< takes one number, not a list"},
        {"display_mode>3", "column 13: display_mode shows no numbers"},
        {"display_mode=fixd display",
         "column 14: \"fixd display\" is not a value of display_mode (fixed display, cycling "
         "display)"},
        {"voltage=high", "column 9: \"high\" is not a number, which voltage shows"},
    };
    for (const Case& c : cases) {
        const std::string message = error(c.expr);
        EXPECT_EQ(message.rfind(c.message, 0), 0U) << c.expr << "\n  got: " << message
                                                    << "\n want: " << c.message;
    }
}

TEST(Trigger, ARegisterNameNeedsItsDevicesProfile) {
    auto none = parse_trigger("voltage>250", trigger_context(nullptr));
    ASSERT_FALSE(none);
    EXPECT_EQ(none.error().message,
              "column 1: unknown term \"voltage\" (kind, slave, function, flag, crc; a "
              "register's name needs its device's profile: --device ADDR=PROFILE or --bus "
              "FILE)");
    EXPECT_EQ(none.error().column, 1);
    // The terms of their own need none.
    EXPECT_TRUE(parse_trigger("flag=txn.no_answer", trigger_context(nullptr)));

    // Another device's profile has no voltage either.
    Bus relay;
    ASSERT_TRUE(relay.assign(5, "zyi-relay"));
    EXPECT_FALSE(parse_trigger("voltage>250", trigger_context(&relay)));
    EXPECT_TRUE(parse_trigger("relay1=on", trigger_context(&relay)))
        << parse_trigger("relay1=on", trigger_context(&relay)).error().message;
}

// The ids flag= takes are exactly the table of docs/formats.md, but for the two it calls
// reserved.
TEST(Trigger, NoteIdsAreThoseOfTheDocs) {
    std::ifstream docs(RTUSCOPE_SOURCE_DIR "/docs/formats.md");
    ASSERT_TRUE(docs);
    std::set<std::string> documented;
    bool in_table = false;
    for (std::string line; std::getline(docs, line);) {
        if (line.rfind("## ", 0) == 0) in_table = line == "## Note ids";
        if (!in_table || line.rfind("| `", 0) != 0) continue;
        const std::string ids = line.substr(0, line.find(" |", 2));
        for (std::size_t at = ids.find('`'); at != std::string::npos;
             at = ids.find('`', ids.find('`', at + 1) + 1)) {
            documented.insert(ids.substr(at + 1, ids.find('`', at + 1) - at - 1));
        }
    }
    documented.erase("frame.split_by_length");
    documented.erase("frame.noise");
    const std::span<const std::string_view> known = known_note_ids();
    EXPECT_EQ(documented, std::set<std::string>(known.begin(), known.end()));
    EXPECT_GT(documented.size(), 20U);
}

// The records of a bundled capture, decoded with its bus file, that fire `triggers`
// (their numbers), checking that every record still reaches the sink behind.
std::vector<std::uint64_t> events_in(const std::string& device,
                                     const std::vector<std::string>& expressions,
                                     std::vector<std::size_t>* fired = nullptr) {
    const std::string dir = RTUSCOPE_SOURCE_DIR "/captures/devices/";
    Bus bus;
    EXPECT_TRUE(load_bus_file(bus, dir + device + ".bus.toml").empty());
    std::vector<Trigger> triggers;
    for (const std::string& expr : expressions) {
        auto t = parse_trigger(expr, trigger_context(&bus));
        if (!t) {
            ADD_FAILURE() << expr << ": " << t.error().message;
            return {};
        }
        triggers.push_back(*t);
    }
    auto source = open_source(dir + device + ".hex", InputFormat::automatic);
    if (!source) {
        ADD_FAILURE() << source.error().to_string();
        return {};
    }
    std::vector<std::uint64_t> events;
    auto collected = std::make_unique<CollectingSink>();
    CollectingSink& all = *collected;
    auto sink = make_trigger_sink(
        std::move(triggers),
        [&](const Record& r, std::size_t index) {
            events.push_back(r.number);
            if (fired != nullptr) fired->push_back(index);
        },
        std::move(collected));
    PipelineOptions options;
    options.bus = &bus;
    EXPECT_TRUE(run_pipeline(**source, options, *sink));
    EXPECT_TRUE(all.ended);
    EXPECT_EQ(all.records.size(), all.totals.records);
    EXPECT_GT(all.records.size(), 0U);
    return events;
}

using Numbers = std::vector<std::uint64_t>;

// captures/devices/README.md: three requests the ZB-UVI485 refuses by silence (13, 14,
// 20), the broadcast (15) awaiting none; the answer hit by line noise (8).
TEST(TriggerOnCaptures, NoAnswerAndBadCrcOfTheUvSensor) {
    EXPECT_EQ(events_in("zb-uvi485", {"flag=txn.no_answer"}), (Numbers{13, 14, 20}));
    EXPECT_EQ(events_in("zb-uvi485", {"crc=bad"}), (Numbers{8}));
    EXPECT_EQ(events_in("zb-uvi485", {"kind=broadcast"}), (Numbers{15}));
    // Any of several: each event once, with the first trigger it fires.
    std::vector<std::size_t> fired;
    EXPECT_EQ(events_in("zb-uvi485", {"crc=bad", "flag=txn.no_answer", "slave=1,kind=request"},
                        &fired),
              (Numbers{1, 3, 8, 11, 13, 14, 20}));
    EXPECT_EQ(fired, (std::vector<std::size_t>{2, 2, 0, 2, 1, 1, 1}));
}

// captures/devices/README.md: the PDU's readings (230.1 V in answer 2), its alarm
// thresholds read (answer 14: 264.0 V, -10.0 °C), written (request 15: -20.0 °C) and the
// 350.0 V alarm written (17), out of its 0-300 V range and refused by exception (18).
TEST(TriggerOnCaptures, ValuesOfThePduAgainstThresholds) {
    EXPECT_EQ(events_in("pdu485", {"voltage>230"}), (Numbers{2}));
    EXPECT_EQ(events_in("pdu485", {"voltage>230.1"}), Numbers{});
    EXPECT_EQ(events_in("pdu485", {"voltage>=230.1"}), (Numbers{2}));
    EXPECT_EQ(events_in("pdu485", {"voltage_high_alarm>250"}), (Numbers{14, 17}));
    EXPECT_EQ(events_in("pdu485", {"voltage_high_alarm>300"}), (Numbers{17}));
    EXPECT_EQ(events_in("pdu485", {"temperature_low_alarm<-15"}), (Numbers{15}));
    EXPECT_EQ(events_in("pdu485", {"flag=value.out_of_range"}), (Numbers{17}));
    EXPECT_EQ(events_in("pdu485", {"kind=exception"}), (Numbers{18}));
    EXPECT_EQ(events_in("pdu485", {"voltage_high_alarm>250,kind=response"}), (Numbers{14}));
    // Labels, a special write's meaning, and a number equal as shown ("0.0").
    EXPECT_EQ(events_in("pdu485", {"baud_rate=9600 baud"}), (Numbers{6, 19, 20}));
    EXPECT_EQ(events_in("pdu485", {"energy=clear the energy counter"}), (Numbers{7, 8}));
    EXPECT_EQ(events_in("pdu485", {"temperature3=0"}), (Numbers{12}));
}

}  // namespace
}  // namespace rtuscope
