#pragma once

#include <cstdint>

namespace rtuscope {

// Sets a baud rate that has no B* constant; false when the driver refuses it.
bool set_custom_baud(int fd, std::uint32_t baud);

}  // namespace rtuscope
