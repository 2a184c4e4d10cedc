// The telemetry sink and the names it gives topics and labels.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace rtuscope
