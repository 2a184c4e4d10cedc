// rtuscope_bench_pty: plays the benchmarks' traffic (bench/traffic.hpp) into a
// pseudo-terminal, for `rtuscope sniff` to read from its slave side as from a serial port.
// The traffic is generated as it is written, never held whole in memory, so that a run
// can last as many frames as wanted (bench/longrun.sh: 50 million).
//
//   rtuscope_bench_pty [--frames N] [--seed S] [--baud B] [--speed X] [--raw FILE]
//
// It prints the slave's path on the first line of stdout, waits until a reader has set
// the port up (PARMRK in its settings, as rtuscope's tty source sets them, then a pause
// for the flush that follows), writes the traffic, waits until the reader has taken every
// byte, and prints on a second line what it sent:
//   sent FRAMES frames (REQUESTS requests, ANSWERS answers, DAMAGED damaged), JUNK junk
//   and noise bytes, BYTES bytes in SECONDS s
// Then it keeps the pseudo-terminal open (closing it would hang up the reader) until it
// is stopped by SIGTERM or SIGINT.
//
// --speed 0 (the default) writes as fast as the reader takes the bytes (the kernel's
// buffer blocks the writer while it is full), which loses the traffic's silences: the
// reader sees one stream, framed by length and CRC alone, as a raw dump is. The bytes go
// out in blocks of whole frames, so that a pause of the writer (a busy machine) falls
// between frames, where the line has its silences, never inside one. --speed X writes each
// chunk at its time in the traffic, X times as fast as recorded.
// --raw FILE also writes the bytes to FILE, a raw dump: what `rtuscope stats FILE
// --input-format raw` makes of them is what the reader should make of them at full speed.
#include <fcntl.h>
#include <fmt/format.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "traffic.hpp"

namespace {

using Clock = std::chrono::steady_clock;

[[noreturn]] void die(const std::string& what) {
    fmt::print(stderr, "rtuscope_bench_pty: {}: {}\n", what, std::strerror(errno));
    std::exit(1);
}

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// The pseudo-terminal: the master written here, the slave held open too (its settings
// read, its input queue watched) without ever being read.
struct Pty {
    int master = -1;
    int slave = -1;
    std::string slave_path;
};

Pty open_pty() {
    Pty pty;
    pty.master = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (pty.master < 0) die("posix_openpt");
    if (grantpt(pty.master) != 0 || unlockpt(pty.master) != 0) die("grantpt/unlockpt");
    const char* name = ptsname(pty.master);  // NOLINT(concurrency-mt-unsafe): one thread
    if (name == nullptr) die("ptsname");
    pty.slave_path = name;
    pty.slave = open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (pty.slave < 0) die(fmt::format("open {}", pty.slave_path));
    // Raw until the reader sets it up: no echo back into the master, no line editing.
    termios tio{};
    if (tcgetattr(pty.slave, &tio) != 0) die("tcgetattr");
    cfmakeraw(&tio);
    if (tcsetattr(pty.slave, TCSANOW, &tio) != 0) die("tcsetattr");
    return pty;
}

// The reader has opened the port and set it up: rtuscope marks errors in the stream
// (PARMRK), then flushes what came before; bytes written before that flush would be lost.
void wait_for_reader(const Pty& pty) {
    for (;;) {
        termios tio{};
        if (tcgetattr(pty.slave, &tio) != 0) die("tcgetattr");
        if ((tio.c_iflag & PARMRK) != 0) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
}

// Until the reader has taken every byte: the slave's input queue empty, three times in a
// row (bytes between the master and that queue are not counted in it).
void wait_until_read(const Pty& pty) {
    for (int empty = 0; empty < 3;) {
        int queued = 0;
        if (ioctl(pty.slave, TIOCINQ, &queued) != 0) die("TIOCINQ");
        empty = queued == 0 ? empty + 1 : 0;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
}

void write_all(int fd, const std::uint8_t* data, std::size_t size) {
    while (size > 0) {
        const ssize_t n = ::write(fd, data, size);
        if (n < 0) {
            if (errno == EINTR) continue;
            die("write to the pseudo-terminal");
        }
        data += n;
        size -= static_cast<std::size_t>(n);
    }
}

struct Sent {
    std::uint64_t requests = 0;
    std::uint64_t answers = 0;
    std::uint64_t damaged = 0;
    std::uint64_t junk_bytes = 0;  // junk and noise
};

}  // namespace

int main(int argc, char** argv) {
    rtuscope::bench::TrafficOptions options;
    double speed = 0;
    std::string raw_path;
    CLI::App app{
        "rtuscope_bench_pty: plays the benchmarks' traffic (bench/traffic.hpp) into a "
        "pseudo-terminal for rtuscope sniff to read"};
    app.add_option("--frames", options.frames, "frames to generate")
        ->capture_default_str()
        ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{10'000'000'000}));
    app.add_option("--seed", options.seed, "seed of the traffic's random choices")
        ->capture_default_str();
    app.add_option("--baud", options.baud, "line speed the traffic's timing follows")
        ->capture_default_str()
        ->check(CLI::Range(std::uint32_t{300}, std::uint32_t{4'000'000}));
    app.add_option("--speed", speed,
                   "write each chunk at its time, this many times as fast as recorded; 0: as "
                   "fast as the reader takes them")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    app.add_option("--raw", raw_path, "also write the bytes to this file (a raw dump)");
    CLI11_PARSE(app, argc, argv);

    File raw;
    if (!raw_path.empty()) {
        raw.reset(std::fopen(raw_path.c_str(), "wb"));
        if (!raw) die(fmt::format("cannot create {}", raw_path));
    }

    // Stopped by SIGTERM or SIGINT, whenever it comes: waited for at the end.
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGTERM);
    sigaddset(&stop_signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

    const Pty pty = open_pty();
    fmt::print("{}\n", pty.slave_path);
    std::fflush(stdout);
    wait_for_reader(pty);

    // As fast as possible, whole frames go out in blocks of some 4 KiB: a write per frame
    // would cost the writer more than the reader.
    constexpr std::size_t kBlock = 4096;
    std::vector<std::uint8_t> block;
    block.reserve(kBlock + 256);
    auto write_block = [&] {
        write_all(pty.master, block.data(), block.size());
        if (raw) std::fwrite(block.data(), 1, block.size(), raw.get());
        block.clear();
    };
    const auto start = Clock::now();
    rtuscope::Nanos first_time = rtuscope::kNoTime;
    auto on_chunk = [&](const rtuscope::Chunk& chunk) {
        if (speed == 0) return;  // whole frames, from on_sent
        if (!rtuscope::has_time(first_time)) first_time = chunk.time;
        std::this_thread::sleep_until(
            start + std::chrono::nanoseconds(static_cast<rtuscope::Nanos>(
                        static_cast<double>(chunk.time - first_time) / speed)));
        block.assign(chunk.bytes.begin(), chunk.bytes.end());
        write_block();
    };
    Sent sent;
    auto on_sent = [&](const rtuscope::bench::SentFrame& s) {
        if (speed == 0) {
            block.insert(block.end(), s.bytes.begin(), s.bytes.end());
            if (block.size() >= kBlock) write_block();
        }
        using What = rtuscope::bench::SentFrame::What;
        switch (s.what) {
            case What::request: ++sent.requests; break;
            case What::answer: ++sent.answers; break;
            case What::junk:
            case What::noise: sent.junk_bytes += s.bytes.size(); break;
        }
        if (s.damaged) ++sent.damaged;
    };
    const auto stats = rtuscope::bench::generate_traffic(options, on_chunk, on_sent);
    write_block();
    raw.reset();
    wait_until_read(pty);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    fmt::print("sent {} frames ({} requests, {} answers, {} damaged), {} junk and noise bytes, "
               "{} bytes in {:.1f} s\n",
               stats.frames, sent.requests, sent.answers, sent.damaged, sent.junk_bytes,
               stats.bytes, seconds);
    std::fflush(stdout);

    int signal = 0;
    sigwait(&stop_signals, &signal);
    close(pty.master);
    close(pty.slave);
    return 0;
}
