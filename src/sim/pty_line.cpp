// The speed and stop bits of a pseudo-terminal, through termios2: its c_ispeed holds the
// rate as a number whether it was set with a B* constant or as a custom rate (BOTHER).
// Kept apart because <asm/termbits.h> and <termios.h> cannot be included together.
#include <asm/ioctls.h>
#include <asm/termbits.h>

#include "sim/sim_util.hpp"

extern "C" int ioctl(int fd, unsigned long request, ...);  // NOLINT: <sys/ioctl.h> clashes

namespace rtuscope::sim {

std::optional<PtyLine> read_pty_line(int master) {
    struct termios2 tio {};
    if (ioctl(master, TCGETS2, &tio) != 0) return std::nullopt;
    // An input speed of 0 means "the output speed" (POSIX).
    const speed_t baud = tio.c_ispeed != 0 ? tio.c_ispeed : tio.c_ospeed;
    if (baud == 0) return std::nullopt;
    return PtyLine{baud, static_cast<std::uint8_t>((tio.c_cflag & CSTOPB) != 0 ? 2 : 1)};
}

}  // namespace rtuscope::sim
