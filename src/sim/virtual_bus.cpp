// VirtualBus: pseudo-terminals joined by a hub thread that copies what one port writes to
// every other port, optionally at the line's character rate, as a shared RS-485 pair would;
// paced, a port set to another baud rate or format gets what its UART would make of the
// line (uart_model.hpp).
#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "input/tty_speed.hpp"
#include "sim/sim.hpp"
#include "sim/sim_util.hpp"
#include "sim/uart_model.hpp"

namespace rtuscope::sim {

namespace {

using Clock = std::chrono::steady_clock;

// A receiver re-reads its port's settings at least this often while the bus is quiet, and
// whenever someone writes: a detector trying one setting after another changes them about
// once a second.
constexpr auto kReceiverRefresh = std::chrono::milliseconds(10);

Nanos to_nanos(Clock::time_point t) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

Clock::time_point from_nanos(Nanos t) {
    return Clock::time_point(
        std::chrono::duration_cast<Clock::duration>(std::chrono::nanoseconds(t)));
}

bool same_line(const LineSettings& a, const LineSettings& b) {
    return a.baud == b.baud && a.data_bits == b.data_bits && a.parity == b.parity &&
           a.stop_bits == b.stop_bits;
}

// Raw mode at once: a pty's line discipline starts in cooked mode with echo on, and an
// echo would put every byte a master wrote straight back on the bus.
Status make_raw(int fd, const LineSettings& line) {
    termios tio{};
    if (tcgetattr(fd, &tio) != 0) return Error{errno_message("cannot read terminal settings")};
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB);
    tio.c_cflag |= line.data_bits == 7 ? CS7 : CS8;
    if (line.parity == 'E' || line.parity == 'O') tio.c_cflag |= PARENB;
    if (line.parity == 'O') tio.c_cflag |= PARODD;
    if (line.stop_bits == 2) tio.c_cflag |= CSTOPB;
    // A pty has no clock, but a sniffer that asks sees the line's speed, and the hub takes a
    // port nobody else configures to be at it.
    cfsetispeed(&tio, standard_speed(line.baud).value_or(B9600));
    cfsetospeed(&tio, standard_speed(line.baud).value_or(B9600));
    if (tcsetattr(fd, TCSANOW, &tio) != 0) {
        return Error{errno_message("cannot set terminal settings")};
    }
    set_line_speed(fd, line.baud);
    return ok_status();
}

}  // namespace

struct VirtualBus::Impl {
    struct Port {
        int master = -1;
        int hub_slave = -1;  // keeps the raw settings alive while nobody else has it open
        std::string path;
        Clock::time_point quiet_until{};  // after a hang-up, so poll does not spin
        std::uint8_t data_bits = 8;       // the receiver's format (set_receiver_format)
        char parity = 'N';
        std::uint64_t receiver_errors = 0;
        // Hub thread only: the port's UART while its settings differ from the line's, and
        // the sequence number of the next queued character it has not been given.
        std::optional<UartResampler> uart;
        std::uint64_t uart_fed = 0;
    };
    struct Pending {
        std::size_t from;
        std::uint8_t byte;
        Clock::time_point release;
        std::uint64_t seq;
    };

    Options options;
    std::vector<Port> ports;
    int wake = -1;
    std::mutex mutex;  // ports' fds: unplug() closes them while the hub runs
    std::atomic<bool> stopping{false};
    std::thread hub;
    std::deque<Pending> queue;  // hub thread only
    std::uint64_t next_seq = 0;
    Clock::time_point line_free{};
    Clock::time_point receivers_read{};
    std::atomic<bool> receivers_changed{false};
    std::vector<Received> received;  // hub thread only, reused
    std::size_t backlog_limit = 0;

    ~Impl() {
        stopping = true;
        if (hub.joinable()) {
            wake_hub();
            hub.join();
        }
        for (Port& p : ports) close_port(p);
        if (wake >= 0) ::close(wake);
    }

    void wake_hub() const {
        const std::uint64_t one = 1;
        [[maybe_unused]] const ssize_t n = ::write(wake, &one, sizeof one);
    }

    static void close_port(Port& p) {
        if (p.master >= 0) ::close(p.master);
        if (p.hub_slave >= 0) ::close(p.hub_slave);
        p.master = -1;
        p.hub_slave = -1;
    }

    void run();
    bool read_port(std::size_t i, Clock::time_point now);
    void deliver(std::size_t from, const std::uint8_t* data, std::size_t size);
    void write_port(Port& p, const std::uint8_t* data, std::size_t size) const;
    void release_due(Clock::time_point now);
    void refresh_receivers(Clock::time_point now);
    void feed_and_take_receivers(Clock::time_point now);
    [[nodiscard]] std::optional<Clock::time_point> next_event() const;
};

void VirtualBus::Impl::run() {
    std::vector<pollfd> fds;
    std::vector<std::size_t> index;
    while (!stopping) {
        const auto now = Clock::now();
        fds.clear();
        index.clear();
        fds.push_back({wake, POLLIN, 0});
        {
            std::lock_guard lock(mutex);
            for (std::size_t i = 0; i < ports.size(); ++i) {
                if (ports[i].master < 0 || ports[i].quiet_until > now) continue;
                fds.push_back({ports[i].master, POLLIN, 0});
                index.push_back(i);
            }
        }
        // Bounded even when idle: a hung-up port is retried, and nothing can block forever.
        auto timeout = std::chrono::nanoseconds(std::chrono::milliseconds(100));
        if (const auto next = next_event()) timeout = std::max(*next - now, Clock::duration{0});
        timespec ts{};
        ts.tv_sec = static_cast<time_t>(timeout.count() / 1'000'000'000);
        ts.tv_nsec = static_cast<long>(timeout.count() % 1'000'000'000);
        const int n = ::ppoll(fds.data(), fds.size(), &ts, nullptr);
        if (n < 0 && errno != EINTR) break;
        if (stopping) break;
        if (n > 0 && (fds[0].revents & POLLIN)) {
            std::uint64_t count = 0;
            [[maybe_unused]] const ssize_t r = ::read(wake, &count, sizeof count);
        }
        const auto after = Clock::now();
        bool written = false;
        if (n > 0) {
            for (std::size_t k = 1; k < fds.size(); ++k) {
                if (fds[k].revents != 0) written = read_port(index[k - 1], after) || written;
            }
        }
        if (options.paced && (written || receivers_changed.exchange(false) ||
                              after - receivers_read >= kReceiverRefresh)) {
            refresh_receivers(after);
        }
        release_due(Clock::now());
    }
}

std::optional<Clock::time_point> VirtualBus::Impl::next_event() const {
    std::optional<Clock::time_point> next;
    if (!queue.empty()) next = queue.front().release;
    for (const Port& p : ports) {
        if (!p.uart) continue;
        if (const auto done = p.uart->next_completion()) {
            const auto at = from_nanos(*done);
            if (!next || at < *next) next = at;
        }
    }
    return next;
}

bool VirtualBus::Impl::read_port(std::size_t i, Clock::time_point now) {
    std::uint8_t buf[512];
    bool any = false;
    for (;;) {
        ssize_t got = 0;
        {
            std::lock_guard lock(mutex);
            if (ports[i].master < 0) return any;  // unplugged meanwhile
            got = ::read(ports[i].master, buf, sizeof buf);
            if (got < 0 && errno != EAGAIN && errno != EINTR) {
                // EIO: no slave open. Cannot happen while the hub holds one, but if it does,
                // do not let a permanently readable fd turn the hub into a busy loop.
                ports[i].quiet_until = now + std::chrono::milliseconds(50);
                return any;
            }
        }
        if (got <= 0) return any;
        any = true;
        const auto size = static_cast<std::size_t>(got);
        if (!options.paced) {
            deliver(i, buf, size);
            continue;
        }
        const auto char_time = std::chrono::nanoseconds(options.line.char_time());
        for (std::size_t k = 0; k < size; ++k) {
            // The wire is shared: a byte goes out after the one before it, whoever sent it,
            // and arrives one character time after it started.
            line_free = std::max(line_free, now) + char_time;
            queue.push_back({i, buf[k], line_free, next_seq++});
        }
    }
}

// A port's receiver: the baud rate and stop bits its opener set on the pty, the format the
// test gave. Matching the line in baud rate and format (stop bits never change what a UART
// receives), or unreadable, it gets the bytes as sent; otherwise its UART's.
void VirtualBus::Impl::refresh_receivers(Clock::time_point now) {
    receivers_read = now;
    const LineSettings& line = options.line;
    std::lock_guard lock(mutex);
    for (Port& p : ports) {
        const auto pty = p.master >= 0 ? read_pty_line(p.master) : std::nullopt;
        const bool differs = pty && (pty->baud != line.baud || p.data_bits != line.data_bits ||
                                     p.parity != line.parity);
        if (!differs) {
            p.uart.reset();
            continue;
        }
        const LineSettings receiver{pty->baud, p.data_bits, p.parity, pty->stop_bits};
        if (p.uart && same_line(p.uart->receiver(), receiver)) continue;
        // A UART set up while the line is busy starts hunting for a start bit there.
        p.uart.emplace(line, receiver, to_nanos(now));
        p.uart_fed = queue.empty() ? next_seq : queue.front().seq;
    }
}

void VirtualBus::Impl::feed_and_take_receivers(Clock::time_point now) {
    const auto char_time = std::chrono::nanoseconds(options.line.char_time());
    const Nanos until = to_nanos(now);
    std::lock_guard lock(mutex);
    for (std::size_t j = 0; j < ports.size(); ++j) {
        Port& p = ports[j];
        if (!p.uart) continue;
        // Every character queued so far goes on the wire at its release less one character
        // time, the first of them no earlier than `now`'s reads: the waveform before `now`
        // is known.
        const std::uint64_t front = queue.empty() ? next_seq : queue.front().seq;
        for (std::size_t k = p.uart_fed > front ? p.uart_fed - front : 0; k < queue.size(); ++k) {
            if (queue[k].from != j)
                p.uart->send(to_nanos(queue[k].release - char_time), queue[k].byte);
        }
        p.uart_fed = next_seq;
        received.clear();
        p.uart->take_until(until, received);
        if (received.empty() || p.master < 0) continue;
        // A pty carries no error marks: the port gets the bytes as received, as from an
        // adapter whose driver reports no errors.
        std::uint8_t bytes[256];
        std::size_t size = 0;
        for (const Received& r : received) {
            if (r.framing_error || r.parity_error) ++p.receiver_errors;
            bytes[size++] = r.byte;
            if (size == sizeof bytes) {
                write_port(p, bytes, size);
                size = 0;
            }
        }
        write_port(p, bytes, size);
    }
}

void VirtualBus::Impl::release_due(Clock::time_point now) {
    if (options.paced) feed_and_take_receivers(now);
    std::uint8_t group[256];
    while (!queue.empty() && queue.front().release <= now) {
        const std::size_t from = queue.front().from;
        std::size_t size = 0;
        while (!queue.empty() && queue.front().release <= now && queue.front().from == from &&
               size < sizeof group) {
            group[size++] = queue.front().byte;
            queue.pop_front();
        }
        deliver(from, group, size);
    }
}

void VirtualBus::Impl::deliver(std::size_t from, const std::uint8_t* data, std::size_t size) {
    std::lock_guard lock(mutex);
    for (std::size_t j = 0; j < ports.size(); ++j) {
        Port& p = ports[j];
        if (j == from || p.master < 0 || p.uart) continue;
        write_port(p, data, size);
    }
}

void VirtualBus::Impl::write_port(Port& p, const std::uint8_t* data, std::size_t size) const {
    if (size == 0) return;
    // Nobody reads a port that has nothing attached (the sniffer's, before it starts):
    // drop its backlog so that whoever opens it later gets at most about a second of
    // old traffic, not everything since the bus was made.
    int waiting = 0;
    if (::ioctl(p.hub_slave, TIOCINQ, &waiting) == 0 &&
        static_cast<std::size_t>(waiting) > backlog_limit) {
        ::tcflush(p.hub_slave, TCIFLUSH);
    }
    std::size_t done = 0;
    bool flushed = false;
    while (done < size) {
        const ssize_t n = ::write(p.master, data + done, size - done);
        if (n > 0) {
            done += static_cast<std::size_t>(n);
        } else if (n < 0 && errno == EINTR) {
            continue;
        } else if (n < 0 && errno == EAGAIN && !flushed) {
            ::tcflush(p.hub_slave, TCIFLUSH);  // full: whoever is there does not read
            flushed = true;
        } else {
            break;  // still full, EIO and the like: the bytes are lost, as on a bad cable
        }
    }
}

VirtualBus::VirtualBus(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

VirtualBus::~VirtualBus() = default;

Result<std::unique_ptr<VirtualBus>> VirtualBus::create(std::size_t ports, Options options) {
    if (ports == 0) return Error{"a virtual bus needs at least one port"};
    auto impl = std::make_unique<Impl>();
    impl->options = options;
    const std::size_t chars_per_second =
        static_cast<std::size_t>(kNanosPerSecond / std::max<Nanos>(options.line.char_time(), 1));
    impl->backlog_limit = std::max<std::size_t>(chars_per_second, 256);
    impl->wake = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (impl->wake < 0) return Error{errno_message("cannot create an eventfd")};
    impl->ports.resize(ports);
    for (Impl::Port& p : impl->ports) {
        p.data_bits = options.line.data_bits;
        p.parity = options.line.parity;
        p.master = ::posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        if (p.master < 0) return Error{errno_message("cannot open pseudo-terminal")};
        if (::grantpt(p.master) != 0 || ::unlockpt(p.master) != 0) {
            return Error{errno_message("cannot unlock pseudo-terminal")};
        }
        char name[128];
        if (::ptsname_r(p.master, name, sizeof name) != 0) {
            return Error{errno_message("cannot name pseudo-terminal")};
        }
        p.path = name;
        p.hub_slave = ::open(name, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        if (p.hub_slave < 0) return Error{errno_message("cannot open " + p.path)};
        if (auto st = make_raw(p.hub_slave, options.line); !st) {
            return Error{p.path + ": " + st.error().message};
        }
    }
    try {
        impl->hub = std::thread([raw = impl.get()] { raw->run(); });
    } catch (const std::system_error& e) {
        return Error{std::string("cannot start the bus thread: ") + e.what()};
    }
    return std::unique_ptr<VirtualBus>(new VirtualBus(std::move(impl)));
}

const std::string& VirtualBus::port_path(std::size_t port) const {
    static const std::string none;
    return port < impl_->ports.size() ? impl_->ports[port].path : none;
}

std::size_t VirtualBus::port_count() const {
    return impl_->ports.size();
}

bool VirtualBus::set_receiver_format(std::size_t port, std::uint8_t data_bits, char parity) {
    if (port >= impl_->ports.size() || data_bits < 5 || data_bits > 8) return false;
    if (parity != 'N' && parity != 'E' && parity != 'O') return false;
    {
        std::lock_guard lock(impl_->mutex);
        impl_->ports[port].data_bits = data_bits;
        impl_->ports[port].parity = parity;
    }
    impl_->receivers_changed = true;
    impl_->wake_hub();
    return true;
}

std::uint64_t VirtualBus::receiver_errors(std::size_t port) const {
    if (port >= impl_->ports.size()) return 0;
    std::lock_guard lock(impl_->mutex);
    return impl_->ports[port].receiver_errors;
}

void VirtualBus::unplug(std::size_t port) {
    if (port >= impl_->ports.size()) return;
    {
        std::lock_guard lock(impl_->mutex);
        Impl::close_port(impl_->ports[port]);
    }
    impl_->wake_hub();
}

}  // namespace rtuscope::sim
