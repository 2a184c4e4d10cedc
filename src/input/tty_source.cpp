// Live serial ports as a ChunkSource: raw termios, PARMRK for parity and framing errors,
// poll() with a short timeout so that the pipeline hears "nothing came until now" and can
// end frames and requests on time.
#include <fcntl.h>
#include <fmt/format.h>
#include <linux/serial.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <ctime>

#include "input/tty.hpp"
#include "input/tty_baud.hpp"
#include "input/tty_speed.hpp"

namespace rtuscope {

void ParmrkDecoder::feed(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out,
                         std::vector<std::uint32_t>& errors) {
    for (const std::uint8_t b : in) {
        if (pending_ == 0) {
            if (b == 0xFF) {
                pending_ = 1;
            } else {
                out.push_back(b);
            }
        } else if (pending_ == 1) {
            if (b == 0xFF) {  // an escaped data byte 0xFF
                out.push_back(0xFF);
                pending_ = 0;
            } else if (b == 0x00) {
                pending_ = 2;
            } else {
                // Not an escape the kernel makes; keep both bytes rather than lose one.
                out.push_back(0xFF);
                out.push_back(b);
                pending_ = 0;
            }
        } else {
            errors.push_back(static_cast<std::uint32_t>(out.size()));
            out.push_back(b);
            pending_ = 0;
        }
    }
}

namespace {

Error open_error(const std::string& path, int err) {
    std::string message = fmt::format("cannot open: {}", std::strerror(err));
    if (err == EACCES || err == EPERM) {
        message +=
            " (serial ports belong to the dialout group: sudo usermod -aG dialout "
            "$USER, then log in again)";
    } else if (err == ENOENT) {
        message += " (is the adapter plugged in? ls /dev/ttyUSB* /dev/ttyACM* /dev/serial/by-id)";
    } else if (err == EBUSY) {
        message += " (another program holds it exclusively)";
    }
    return Error{message, path};
}

struct Port {
    std::string path;
    std::string channel;
    int fd = -1;
    ParmrkDecoder parmrk;
};

class TtySource final : public ChunkSource {
  public:
    TtySource(TtyOptions options, std::vector<Port> ports)
        : options_(std::move(options)), ports_(std::move(ports)) {
        info_.name = ports_.front().path;
        for (std::size_t i = 1; i < ports_.size(); ++i) info_.name += " + " + ports_[i].path;
        info_.format = "live";
        info_.line = options_.line;
        info_.timed = true;
        info_.time_base = TimeBase::unix_time;  // the real-time clock
        // Wall time for the capture file and the output, steady time for the gaps.
        mono_start_ = clock_ns(CLOCK_MONOTONIC);
        wall_start_ = clock_ns(CLOCK_REALTIME);
    }
    ~TtySource() override {
        for (Port& p : ports_) {
            if (p.fd >= 0) close(p.fd);
        }
    }
    TtySource(const TtySource&) = delete;
    TtySource& operator=(const TtySource&) = delete;

    [[nodiscard]] const SourceInfo& info() const override { return info_; }

    Result<bool> next(Chunk& out) override {
        out.bytes.clear();
        out.char_errors.clear();
        out.source_line = 0;
        // A second port's bytes read together with the first's are handed over next.
        if (!queued_.empty()) {
            out = std::move(queued_.back());
            queued_.pop_back();
            return true;
        }
        for (;;) {
            if (options_.stop != nullptr && options_.stop->load()) return false;
            const Nanos now = clock_ns(CLOCK_MONOTONIC);
            if (options_.duration && now - mono_start_ >= *options_.duration) return false;

            std::array<pollfd, 2> fds{};
            for (std::size_t i = 0; i < ports_.size(); ++i) fds[i] = {ports_[i].fd, POLLIN, 0};
            const int ready =
                poll(fds.data(), ports_.size(), static_cast<int>(options_.tick / 1'000'000));
            if (ready < 0) {
                if (errno == EINTR) continue;  // a signal: the stop flag says what to do
                return Error{fmt::format("poll: {}", std::strerror(errno)), info_.name};
            }
            const Nanos at = to_wall(clock_ns(CLOCK_MONOTONIC));
            if (ready == 0) {
                out.time = at;  // nothing came: a tick
                out.channel.clear();
                return true;
            }
            std::vector<Chunk> got;
            for (std::size_t i = 0; i < ports_.size(); ++i) {
                if (fds[i].revents == 0) continue;
                Chunk chunk;
                if (Status s = read_port(ports_[i], fds[i].revents, at, chunk); !s) {
                    return s.error();
                }
                if (!chunk.bytes.empty()) got.push_back(std::move(chunk));
            }
            if (got.empty()) continue;
            out = std::move(got.front());
            for (std::size_t i = got.size(); i > 1; --i) queued_.push_back(std::move(got[i - 1]));
            return true;
        }
    }

  private:
    Nanos to_wall(Nanos mono) const { return wall_start_ + (mono - mono_start_); }

    static Status read_port(Port& port, short revents, Nanos at, Chunk& chunk) {
        std::array<std::uint8_t, 4096> buffer{};
        const ssize_t n = read(port.fd, buffer.data(), buffer.size());
        if (n < 0 && (errno == EAGAIN || errno == EINTR)) return ok_status();
        if (n <= 0 || (revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) {
            const int err = n < 0 ? errno : EIO;
            return Error{fmt::format("the port went away ({}); was the adapter unplugged?",
                                     std::strerror(err)),
                         port.path};
        }
        chunk.time = at;
        chunk.channel = port.channel;
        port.parmrk.feed(std::span(buffer.data(), static_cast<std::size_t>(n)), chunk.bytes,
                         chunk.char_errors);
        return ok_status();
    }

    TtyOptions options_;
    std::vector<Port> ports_;
    SourceInfo info_;
    Nanos mono_start_ = 0;
    Nanos wall_start_ = 0;
    std::vector<Chunk> queued_;
};

Status configure(Port& port, const LineSettings& line, std::vector<std::string>& notices) {
    if (!isatty(port.fd)) {
        return Error{"not a serial port (to decode a file, use rtuscope decode)", port.path};
    }
    termios tio{};
    if (tcgetattr(port.fd, &tio) != 0) {
        return Error{fmt::format("cannot read its settings: {}", std::strerror(errno)), port.path};
    }
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
    static constexpr std::array<tcflag_t, 4> kSizes = {CS5, CS6, CS7, CS8};
    tio.c_cflag |= kSizes[static_cast<std::size_t>(line.data_bits - 5)];
    if (line.parity != 'N') tio.c_cflag |= PARENB;
    if (line.parity == 'O') tio.c_cflag |= PARODD;
    if (line.stop_bits == 2) tio.c_cflag |= CSTOPB;
    // Mark parity and framing errors in the stream (0xFF 0x00 byte) instead of dropping
    // the byte or turning it into 0: a sniffer must show what was wrong and where.
    tio.c_iflag &= ~static_cast<tcflag_t>(IGNPAR | IGNBRK | BRKINT | ISTRIP | IXON | IXOFF);
    tio.c_iflag |= PARMRK;
    if (line.parity != 'N') tio.c_iflag |= INPCK;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    const auto speed = standard_speed(line.baud);
    if (speed) {
        cfsetispeed(&tio, *speed);
        cfsetospeed(&tio, *speed);
    }
    if (tcsetattr(port.fd, TCSANOW, &tio) != 0) {
        return Error{fmt::format("cannot set the line settings: {}", std::strerror(errno)),
                     port.path};
    }
    if (!speed && !set_custom_baud(port.fd, line.baud)) {
        return Error{fmt::format("the driver does not support {} baud", line.baud), port.path};
    }
    // Low latency makes USB adapters hand bytes over at once rather than every 16 ms.
    serial_struct serial{};
    if (ioctl(port.fd, TIOCGSERIAL, &serial) == 0) {
        serial.flags |= ASYNC_LOW_LATENCY;
        if (ioctl(port.fd, TIOCSSERIAL, &serial) != 0) {
            notices.push_back(
                fmt::format("{}: the driver refuses low-latency mode ({}); timing "
                            "is as coarse as it delivers bytes",
                            port.path, std::strerror(errno)));
        }
    } else if (port.path.rfind("/dev/pts/", 0) != 0) {  // a pseudo-terminal has no UART
        notices.push_back(
            fmt::format("{}: no low-latency mode ({}); timing is as coarse as "
                        "the driver delivers bytes",
                        port.path, std::strerror(errno)));
    }
    tcflush(port.fd, TCIFLUSH);  // what was buffered before we listened has no time
    return ok_status();
}

}  // namespace

Result<std::unique_ptr<ChunkSource>> open_tty_source(const TtyOptions& options,
                                                     std::vector<std::string>* notices) {
    if (options.ports.empty() || options.ports.size() > 2) {
        return Error{"sniff takes one port, or two for a full-duplex tap"};
    }
    std::vector<Port> ports;
    std::vector<std::string> said;
    for (std::size_t i = 0; i < options.ports.size(); ++i) {
        Port port;
        port.path = options.ports[i];
        if (options.ports.size() > 1) {
            port.channel = i < options.channels.size() ? options.channels[i]
                                                       : std::string(i == 0 ? "master" : "slave");
        }
        // Read-only: a passive tool must not be able to disturb the bus.
        port.fd = open(port.path.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        if (port.fd < 0) {
            const int err = errno;
            for (Port& p : ports) close(p.fd);
            return open_error(port.path, err);
        }
        ports.push_back(std::move(port));
        if (Status s = configure(ports.back(), options.line, said); !s) {
            for (Port& p : ports) close(p.fd);
            return s.error();
        }
    }
    if (notices != nullptr) *notices = std::move(said);
    return std::unique_ptr<ChunkSource>(new TtySource(options, std::move(ports)));
}

}  // namespace rtuscope
