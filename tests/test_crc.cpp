#include <gtest/gtest.h>

#include <array>
#include <string_view>
#include <vector>

#include "rtuscope/crc.hpp"

namespace rtuscope {
namespace {

std::vector<std::uint8_t> bytes_of(std::string_view text) {
    return {text.begin(), text.end()};
}

TEST(Crc, PublishedCheckValue) {
    // CRC-16/MODBUS check value from the CRC catalogue (Greg Cook, "crc-16-modbus").
    EXPECT_EQ(crc16_modbus(bytes_of("123456789")), 0x4B37);
}

TEST(Crc, EmptyInputIsInitialValue) {
    EXPECT_EQ(crc16_modbus({}), 0xFFFF);
}

TEST(Crc, ModbusSerialLineSpecExample) {
    // Modbus over Serial Line v1.02: read of 0x006B x3 from slave 0x11 ends 76 87.
    const std::array<std::uint8_t, 8> frame{0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x76, 0x87};
    EXPECT_EQ(check_crc(frame).status, CrcStatus::ok);
}

TEST(Crc, ManualFramesOkBadAndSwapped) {
    const std::array<std::uint8_t, 8> ok{0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0xC4, 0x0B};
    EXPECT_EQ(check_crc(ok).status, CrcStatus::ok);
    EXPECT_EQ(check_crc(ok).expected, 0x0BC4);

    const std::array<std::uint8_t, 8> swapped{0x01, 0x03, 0x00, 0x00, 0x00, 0x02, 0x0B, 0xC4};
    EXPECT_EQ(check_crc(swapped).status, CrcStatus::swapped);

    // ZB-UVI485 manual example 5: the CRC printed there is wrong.
    const std::array<std::uint8_t, 7> bad{0x02, 0x03, 0x02, 0x18, 0x18, 0xB6, 0x4E};
    const auto check = check_crc(bad);
    EXPECT_EQ(check.status, CrcStatus::bad);
    EXPECT_EQ(check.received, 0x4EB6);
    EXPECT_NE(check.expected, check.received);
}

TEST(Crc, FrameFollowedByZeroAlsoPassesNaiveCheck) {
    // Why the framer cannot trust "last two bytes are the CRC" alone: any frame followed
    // by 00 passes that test one byte longer.
    const std::array<std::uint8_t, 9> frame{0x01, 0x03, 0x04, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00};
    std::array<std::uint8_t, 9> f = frame;
    const auto crc = crc16_modbus(std::span(f).first(6));
    f[6] = static_cast<std::uint8_t>(crc & 0xFF);
    f[7] = static_cast<std::uint8_t>(crc >> 8);
    EXPECT_EQ(check_crc(std::span(f).first(8)).status, CrcStatus::ok);
    EXPECT_EQ(check_crc(f).status, CrcStatus::ok);
}

TEST(Crc, TooShortIsBad) {
    const std::array<std::uint8_t, 2> two{0x01, 0x03};
    EXPECT_EQ(check_crc(two).status, CrcStatus::bad);
}

}  // namespace
}  // namespace rtuscope
