// Any baud rate the driver accepts, through termios2/BOTHER. Kept apart because
// <asm/termbits.h> and <termios.h> cannot be included together.
#include "input/tty_baud.hpp"

#include <asm/ioctls.h>
#include <asm/termbits.h>

extern "C" int ioctl(int fd, unsigned long request, ...);  // NOLINT: <sys/ioctl.h> clashes

namespace rtuscope {

bool set_custom_baud(int fd, std::uint32_t baud) {
    struct termios2 tio {};
    if (ioctl(fd, TCGETS2, &tio) != 0) return false;
    tio.c_cflag &= ~static_cast<tcflag_t>(CBAUD);
    tio.c_cflag |= BOTHER;
    tio.c_ispeed = baud;
    tio.c_ospeed = baud;
    if (ioctl(fd, TCSETS2, &tio) != 0) return false;
    // Drivers round to what their clock can make; more than 2 % off garbles the line.
    if (ioctl(fd, TCGETS2, &tio) != 0) return false;
    const auto got = static_cast<double>(tio.c_ispeed);
    return got > baud * 0.98 && got < baud * 1.02;
}

}  // namespace rtuscope
