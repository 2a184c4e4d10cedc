// Live serial ports as a ChunkSource: raw termios, PARMRK for parity and framing errors,
// poll() with a short timeout so that the pipeline hears "nothing came until now" and can
// end frames and requests on time.
#include <fcntl.h>
#include <fmt/format.h>
#include <linux/serial.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <ctime>

#include "input/tty.hpp"
#include "input/tty_baud.hpp"
#include "input/tty_port.hpp"
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

Nanos ReadBatcher::stamp(Nanos now, std::size_t count) {
    if (count == 0) {
        batching_ = false;  // the line fell silent: the next byte wakes the reader
        return now;
    }
    Nanos end = now;
    // A read long after its window (the pipeline was busy elsewhere) knows no more than
    // when it came, like the first read after a silence.
    if (batching_ && now - last_read_ <= 2 * window_) {
        // The line was busy when the port was last read: these bytes follow on from then.
        const Nanos bytes_time = static_cast<Nanos>(count) * char_time_;
        end = std::min(now, last_read_ + bytes_time);
        // A window the bytes did not fill had a silence in it.
        batching_ = now - last_read_ - bytes_time <= char_time_;
    } else {
        batching_ = true;  // a frame has begun
    }
    last_read_ = now;
    return end;
}

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

namespace {

struct Port {
    std::string path;
    std::string channel;
    int fd = -1;
    ParmrkDecoder parmrk;
    ReadBatcher batcher;
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
        reuse(out);
        // A second port's bytes read together with the first's are handed over next.
        if (second_ready_) {
            second_ready_ = false;
            std::swap(out, reads_[1]);
            return true;
        }
        for (;;) {
            if (options_.stop != nullptr && options_.stop->load()) return false;
            const Nanos now = clock_ns(CLOCK_MONOTONIC);
            if (options_.duration && now - mono_start_ >= *options_.duration) return false;

            // A port in the middle of a frame is read when its window ends, not at its
            // next byte (ReadBatcher).
            int timeout_ms = static_cast<int>(options_.tick / 1'000'000);
            if (const Nanos due = next_batch_read(); has_time(due)) {
                const timespec until{static_cast<time_t>(due / kNanosPerSecond),
                                     static_cast<long>(due % kNanosPerSecond)};
                if (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) != 0) {
                    continue;  // a signal: the stop flag says what to do
                }
                timeout_ms = 0;
            }
            std::array<pollfd, 2> fds{};
            for (std::size_t i = 0; i < ports_.size(); ++i) fds[i] = {ports_[i].fd, POLLIN, 0};
            const int ready = poll(fds.data(), ports_.size(), timeout_ms);
            if (ready < 0) {
                if (errno == EINTR) continue;  // a signal: the stop flag says what to do
                return Error{fmt::format("poll: {}", std::strerror(errno)), info_.name};
            }
            const Nanos read_at = clock_ns(CLOCK_MONOTONIC);
            // Each port's read goes into its own chunk, whose buffers are kept from call
            // to call (swapped with the caller's).
            std::size_t with_bytes = 0;
            for (std::size_t i = 0; i < ports_.size(); ++i) {
                Port& port = ports_[i];
                Chunk& chunk = reads_[i];
                reuse(chunk);
                if (fds[i].revents != 0) {
                    if (Status s = read_port(port, fds[i].revents, chunk); !s) {
                        if (!options_.reopen) return s.error();
                        return wait_for_ports(s.error(), out);
                    }
                } else if (!port.batcher.batching()) {
                    continue;
                }
                chunk.time = to_wall(port.batcher.stamp(read_at, chunk.bytes.size()));
                if (!chunk.bytes.empty()) ++with_bytes;
            }
            if (with_bytes == 0) {
                if (ready != 0) continue;
                out.time = to_wall(read_at);  // nothing came: a tick
                out.channel.clear();
                return true;
            }
            const std::size_t first = reads_[0].bytes.empty() ? 1 : 0;
            std::swap(out, reads_[first]);
            second_ready_ = with_bytes == 2;
            return true;
        }
    }

    [[nodiscard]] std::vector<std::string> remarks() const override { return gaps_; }

  private:
    // A port went away (`why`): every port is closed, then opened again with the same
    // settings once it is back; `out` is then the chunk that says how long nothing was
    // heard. False when the run is stopped while waiting.
    Result<bool> wait_for_ports(const Error& why, Chunk& out) {
        const Nanos gone_at = to_wall(clock_ns(CLOCK_MONOTONIC));
        for (Port& p : ports_) {
            if (p.fd >= 0) ::close(p.fd);
            p.fd = -1;
        }
        tell(fmt::format("{}; waiting for it to come back (--reopen)", why.to_string()));
        for (;;) {
            const timespec pause{static_cast<time_t>(options_.reopen_poll / kNanosPerSecond),
                                 static_cast<long>(options_.reopen_poll % kNanosPerSecond)};
            nanosleep(&pause, nullptr);  // a signal ends it early: the stop flag says
            if (options_.stop != nullptr && options_.stop->load()) return false;
            const Nanos now = clock_ns(CLOCK_MONOTONIC);
            if (options_.duration && now - mono_start_ >= *options_.duration) return false;
            if (reopen_ports()) break;
        }
        const Nanos back_at = to_wall(clock_ns(CLOCK_MONOTONIC));
        const std::string gap = fmt::format(
            "{} was gone from {} to {} ({:.1f} s) and was opened again: nothing was heard then",
            info_.name, utc_text(gone_at), utc_text(back_at),
            static_cast<double>(back_at - gone_at) / 1e9);
        tell(gap);
        gaps_.push_back(gap);
        reuse(out);
        out.time = back_at;
        out.gap_since = gone_at;
        for (Port& p : ports_) p.batcher = ReadBatcher(options_.line);
        return true;
    }

    // Opens every port again; false (all closed) while one is still missing.
    bool reopen_ports() {
        std::vector<std::string> ignored;
        for (Port& p : ports_) {
            p.fd = open(p.path.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
            if (p.fd < 0 ||
                !configure_port(p.fd, p.path, options_.line, ErrorMarks::as_the_format_checks,
                                ignored)) {
                for (Port& q : ports_) {
                    if (q.fd >= 0) ::close(q.fd);
                    q.fd = -1;
                }
                return false;
            }
            p.parmrk = ParmrkDecoder{};
        }
        return true;
    }

    void tell(const std::string& notice) const {
        if (options_.on_notice) options_.on_notice(notice);
    }

    // A chunk as new, with the room its buffers had.
    static void reuse(Chunk& chunk) {
        std::vector<std::uint8_t> bytes = std::move(chunk.bytes);
        std::vector<std::uint32_t> errors = std::move(chunk.char_errors);
        chunk = Chunk{};
        bytes.clear();
        errors.clear();
        chunk.bytes = std::move(bytes);
        chunk.char_errors = std::move(errors);
    }

    Nanos to_wall(Nanos mono) const { return wall_start_ + (mono - mono_start_); }

    // The earliest window's end among the ports that are batching; none when no port is.
    Nanos next_batch_read() const {
        Nanos due = kNoTime;
        for (const Port& p : ports_) {
            if (p.batcher.batching() && (!has_time(due) || p.batcher.next_read() < due)) {
                due = p.batcher.next_read();
            }
        }
        return due;
    }

    static Status read_port(Port& port, short revents, Chunk& chunk) {
        chunk.channel = port.channel;
        return read_marked(port.fd, port.path, revents, port.parmrk, chunk);
    }

    TtyOptions options_;
    std::vector<Port> ports_;
    SourceInfo info_;
    Nanos mono_start_ = 0;
    Nanos wall_start_ = 0;
    std::array<Chunk, 2> reads_;
    bool second_ready_ = false;  // both ports had bytes: reads_[1] is handed over next
    std::vector<std::string> gaps_;  // what each wait for a port that went away was
};

}  // namespace

namespace {

// A pseudo-terminal carries bytes, not characters: Linux keeps it at 8 data bits without
// parity whatever is asked, and glibc reports that as EINVAL once it has set the rest.
bool is_pseudo_terminal(int fd) {
    struct stat st {};
    // The Unix98 pty slaves' majors (Documentation/admin-guide/devices.txt).
    return fstat(fd, &st) == 0 && S_ISCHR(st.st_mode) && major(st.st_rdev) >= 136 &&
           major(st.st_rdev) <= 143;
}

}  // namespace

Status configure_port(int fd, const std::string& path, const LineSettings& line,
                      ErrorMarks marks, std::vector<std::string>& notices) {
    if (!isatty(fd)) {
        return Error{"not a serial port (to decode a file, use rtuscope decode)", path};
    }
    termios tio{};
    if (tcgetattr(fd, &tio) != 0) {
        return Error{fmt::format("cannot read its settings: {}", std::strerror(errno)), path};
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
    if (line.parity != 'N' || marks == ErrorMarks::parity_and_framing) tio.c_iflag |= INPCK;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    const auto speed = standard_speed(line.baud);
    if (speed) {
        cfsetispeed(&tio, *speed);
        cfsetospeed(&tio, *speed);
    }
    if (tcsetattr(fd, TCSANOW, &tio) != 0 && !(errno == EINVAL && is_pseudo_terminal(fd))) {
        return Error{fmt::format("cannot set the line settings: {}", std::strerror(errno)),
                     path};
    }
    if (!speed && !set_custom_baud(fd, line.baud)) {
        return Error{fmt::format("the driver does not support {} baud", line.baud), path};
    }
    // Low latency makes USB adapters hand bytes over at once rather than every 16 ms.
    serial_struct serial{};
    if (ioctl(fd, TIOCGSERIAL, &serial) == 0) {
        serial.flags |= ASYNC_LOW_LATENCY;
        if (ioctl(fd, TIOCSSERIAL, &serial) != 0) {
            notices.push_back(
                fmt::format("{}: the driver refuses low-latency mode ({}); timing "
                            "is as coarse as it delivers bytes",
                            path, std::strerror(errno)));
        }
    } else if (path.rfind("/dev/pts/", 0) != 0) {  // a pseudo-terminal has no UART
        notices.push_back(
            fmt::format("{}: no low-latency mode ({}); timing is as coarse as "
                        "the driver delivers bytes",
                        path, std::strerror(errno)));
    }
    tcflush(fd, TCIFLUSH);  // what was buffered before we listened has no time
    return ok_status();
}

Status read_marked(int fd, const std::string& path, short revents, ParmrkDecoder& parmrk,
                   Chunk& chunk) {
    std::array<std::uint8_t, 4096> buffer{};
    const ssize_t n = read(fd, buffer.data(), buffer.size());
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return ok_status();
    if (n <= 0 || (revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) {
        const int err = n < 0 ? errno : EIO;
        return Error{fmt::format("the port went away ({}); was the adapter unplugged?",
                                 std::strerror(err)),
                     path};
    }
    parmrk.feed(std::span(buffer.data(), static_cast<std::size_t>(n)), chunk.bytes,
                chunk.char_errors);
    return ok_status();
}

Result<std::unique_ptr<ChunkSource>> open_tty_source(const TtyOptions& options,
                                                     std::vector<std::string>* notices) {
    if (options.ports.empty() || options.ports.size() > 2) {
        return Error{"sniff takes one port, or two for a full-duplex tap"};
    }
    std::vector<Port> ports;
    std::vector<std::string> said;
    for (std::size_t i = 0; i < options.ports.size(); ++i) {
        Port port{.path = options.ports[i],
                  .channel = {},
                  .fd = -1,
                  .parmrk = {},
                  .batcher = ReadBatcher(options.line)};
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
        if (Status s = configure_port(ports.back().fd, ports.back().path, options.line,
                                      ErrorMarks::as_the_format_checks, said);
            !s) {
            for (Port& p : ports) close(p.fd);
            return s.error();
        }
    }
    if (notices != nullptr) *notices = std::move(said);
    return std::unique_ptr<ChunkSource>(new TtySource(options, std::move(ports)));
}

}  // namespace rtuscope
