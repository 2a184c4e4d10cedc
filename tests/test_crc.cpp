#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <span>
#include <string_view>
#include <vector>

#include "framing/crc.hpp"

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

// The table-driven CRC goes 8, 4, 2 and 1 bytes at a time: every length and every split
// point must agree with the CRC computed bit by bit, as the specification describes it.
TEST(Crc, EveryLengthAndSplitAgreesWithTheBitwiseDefinition) {
    auto bitwise = [](std::span<const std::uint8_t> bytes) {
        std::uint16_t crc = 0xFFFF;
        for (const std::uint8_t byte : bytes) {
            crc ^= byte;
            for (int bit = 0; bit < 8; ++bit) {
                crc = (crc & 1U) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001U)
                                 : static_cast<std::uint16_t>(crc >> 1);
            }
        }
        return crc;
    };
    std::vector<std::uint8_t> data(300);
    std::uint32_t state = 12345;
    for (auto& byte : data) {
        state = state * 1103515245U + 12345U;
        byte = static_cast<std::uint8_t>(state >> 16);
    }
    for (std::size_t n = 0; n <= data.size(); ++n) {
        const auto bytes = std::span(data).first(n);
        const std::uint16_t expected = bitwise(bytes);
        ASSERT_EQ(crc16_modbus(bytes), expected) << n << " bytes";
        for (std::size_t split = 0; split <= std::min<std::size_t>(n, 20); ++split) {
            ASSERT_EQ(crc16_modbus_update(crc16_modbus(bytes.first(split)), bytes.subspan(split)),
                      expected)
                << n << " bytes split at " << split;
        }
        std::uint16_t byte_by_byte = 0xFFFF;
        for (const std::uint8_t byte : bytes) byte_by_byte = crc16_modbus_byte(byte_by_byte, byte);
        ASSERT_EQ(byte_by_byte, expected) << n << " bytes one at a time";
        std::uint16_t two_at_a_time = 0xFFFF;
        for (std::size_t i = 0; i + 1 < n; i += 2) {
            two_at_a_time = crc16_modbus_2(two_at_a_time, bytes[i], bytes[i + 1]);
        }
        if (n % 2 == 1) two_at_a_time = crc16_modbus_byte(two_at_a_time, bytes[n - 1]);
        ASSERT_EQ(two_at_a_time, expected) << n << " bytes two at a time";
        if (n >= 4) {
            const auto after =
                crc16_modbus_each_of_4(crc16_modbus(bytes.first(n - 4)), bytes.data() + n - 4);
            for (std::size_t k = 0; k < 4; ++k) {
                ASSERT_EQ(after[k], bitwise(bytes.first(n - 3 + k)))
                    << n - 4 << " bytes, then " << k + 1 << " of four";
            }
        }
    }
}

TEST(Crc, TooShortIsBad) {
    const std::array<std::uint8_t, 2> two{0x01, 0x03};
    EXPECT_EQ(check_crc(two).status, CrcStatus::bad);
}

}  // namespace
}  // namespace rtuscope
