#include "input/tty_listener.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include "input/tty.hpp"
#include "input/tty_port.hpp"

namespace rtuscope {

struct TtyListener::Port {
    std::string path;
    std::string channel;
    int fd = -1;
    termios saved{};
    ParmrkDecoder parmrk;
};

namespace {

Nanos monotonic_now() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<Nanos>(ts.tv_sec) * kNanosPerSecond + ts.tv_nsec;
}

}  // namespace

Result<std::unique_ptr<TtyListener>> TtyListener::open(const std::vector<std::string>& paths,
                                                       std::vector<std::string>* notices) {
    if (paths.empty() || paths.size() > 2) {
        return Error{"detect takes one port, or two for a full-duplex tap"};
    }
    std::vector<Port> ports;
    const auto close_all = [&] {
        for (Port& p : ports) {
            tcsetattr(p.fd, TCSANOW, &p.saved);
            close(p.fd);
        }
    };
    for (std::size_t i = 0; i < paths.size(); ++i) {
        Port port;
        port.path = paths[i];
        if (paths.size() > 1) port.channel = i == 0 ? "master" : "slave";
        // Read-only: a passive tool must not be able to disturb the bus.
        port.fd = ::open(port.path.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        if (port.fd < 0) {
            const int err = errno;
            close_all();
            return open_error(port.path, err);
        }
        if (!isatty(port.fd)) {
            close(port.fd);
            close_all();
            return Error{"not a serial port (to find the settings of a capture, give its file)",
                         port.path};
        }
        if (tcgetattr(port.fd, &port.saved) != 0) {
            const int err = errno;
            close(port.fd);
            close_all();
            return Error{fmt::format("cannot read its settings: {}", std::strerror(err)),
                         port.path};
        }
        ports.push_back(std::move(port));
    }
    // What the driver refuses is said once, not at every setting tried.
    std::vector<std::string> said;
    for (Port& p : ports) {
        if (Status s = configure_port(p.fd, p.path, LineSettings{}, ErrorMarks::parity_and_framing,
                                      said);
            !s) {
            close_all();
            return s.error();
        }
    }
    if (notices != nullptr) *notices = std::move(said);
    return std::unique_ptr<TtyListener>(new TtyListener(std::move(ports)));
}

TtyListener::TtyListener(std::vector<Port> ports) : ports_(std::move(ports)) {}

TtyListener::~TtyListener() {
    for (Port& p : ports_) {
        tcsetattr(p.fd, TCSANOW, &p.saved);
        close(p.fd);
    }
}

Result<Nanos> TtyListener::listen(const LineSettings& line, Nanos most, const Enough& enough,
                                  std::vector<Chunk>& out, const std::atomic<bool>* stop) {
    std::vector<std::string> ignored;  // said when the ports were opened
    for (Port& p : ports_) {
        if (Status s = configure_port(p.fd, p.path, line, ErrorMarks::parity_and_framing, ignored);
            !s) {
            return s.error();
        }
        p.parmrk = {};
    }
    const std::size_t first = out.size();
    const Nanos start = monotonic_now();
    // A port that changes speed while a character is arriving makes garbage of it, and an
    // adapter takes a moment to apply new settings: what comes at once is not heard.
    constexpr Nanos kSettle = 20'000'000;
    constexpr Nanos kAskEvery = 50'000'000;
    Nanos next_ask = start + kAskEvery;
    std::vector<pollfd> fds;
    for (const Port& p : ports_) fds.push_back({p.fd, POLLIN, 0});
    for (;;) {
        const Nanos now = monotonic_now();
        const Nanos listened = now - start;
        if (listened >= most || (stop != nullptr && stop->load())) return listened;
        if (enough && now >= next_ask) {
            next_ask = now + kAskEvery;
            if (enough(std::span(out).subspan(first), listened)) return listened;
        }
        const Nanos wait = std::min<Nanos>(most - listened, kAskEvery);
        const int n = poll(fds.data(), fds.size(), static_cast<int>(wait / 1'000'000) + 1);
        if (n < 0) {
            if (errno == EINTR) continue;
            return Error{fmt::format("cannot wait for the port: {}", std::strerror(errno))};
        }
        for (std::size_t i = 0; i < fds.size(); ++i) {
            if (fds[i].revents == 0) continue;
            Port& p = ports_[i];
            Chunk chunk;
            if (Status s = read_marked(p.fd, p.path, fds[i].revents, p.parmrk, chunk); !s) {
                return s.error();
            }
            chunk.time = monotonic_now();
            if (chunk.time - start < kSettle) continue;
            chunk.channel = p.channel;
            if (!chunk.bytes.empty()) out.push_back(std::move(chunk));
        }
    }
}

}  // namespace rtuscope
