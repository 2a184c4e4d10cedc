// A serial port (or the two of a full-duplex tap) listened to at one line setting after
// another, for `rtuscope detect`: opened read-only, never written to, and left with the
// settings it had when opened.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "framing/line_settings.hpp"
#include "input/chunk.hpp"
#include "util/result.hpp"
#include "util/time.hpp"

namespace rtuscope {

class TtyListener {
  public:
    // Errors as open_tty_source's. What the user should be told once (a driver that
    // refuses low-latency mode) goes to `notices`.
    static Result<std::unique_ptr<TtyListener>> open(const std::vector<std::string>& ports,
                                                     std::vector<std::string>* notices);
    ~TtyListener();  // puts every port's settings back as they were
    TtyListener(const TtyListener&) = delete;
    TtyListener& operator=(const TtyListener&) = delete;

    // Whether it has heard enough: the chunks so far and how long it has listened. Asked
    // every 50 ms.
    using Enough = std::function<bool(std::span<const Chunk> chunks, Nanos listened)>;
    // Sets `line` on the ports, drops what they buffered, and appends to `out` what they
    // give, one chunk per read stamped when read (monotonic time; a channel per port of a
    // tap), with the bytes received with a parity or framing error marked, until `most`
    // has passed, `enough` says so or `stop` is set; what comes in the first 20 ms, while
    // the port settles, is dropped. Returns how long it listened.
    Result<Nanos> listen(const LineSettings& line, Nanos most, const Enough& enough,
                         std::vector<Chunk>& out, const std::atomic<bool>* stop = nullptr);

    struct Port;

  private:
    explicit TtyListener(std::vector<Port> ports);
    std::vector<Port> ports_;
};

}  // namespace rtuscope
