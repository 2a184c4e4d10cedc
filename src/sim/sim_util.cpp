// Private helpers of the simulator (see sim_util.hpp).
#include "sim/sim_util.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <span>

#include "framing/crc.hpp"
#include "input/tty_baud.hpp"
#include "input/tty_speed.hpp"

namespace rtuscope::sim {

std::string errno_message(const std::string& what) {
    return what + ": " + std::strerror(errno);
}

std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> body) {
    const std::uint16_t crc = crc16_modbus(body);
    body.push_back(static_cast<std::uint8_t>(crc & 0xFF));
    body.push_back(static_cast<std::uint8_t>(crc >> 8));
    return body;
}

void set_line_speed(int fd, std::uint32_t baud) {
    if (!standard_speed(baud)) set_custom_baud(fd, baud);
}

bool write_all(int fd, const std::vector<std::uint8_t>& bytes, std::chrono::milliseconds timeout) {
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n > 0) {
            done += static_cast<std::size_t>(n);
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && errno != EAGAIN) return false;
        pollfd p{fd, POLLOUT, 0};
        if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return false;
        if (p.revents & (POLLERR | POLLHUP | POLLNVAL)) return false;
    }
    return true;
}

namespace {

constexpr std::size_t kMaxFrame = 256;  // Modbus over Serial Line 2.5.1: RTU ADU limit

bool crc_ok(const std::vector<std::uint8_t>& b, std::size_t n) {
    if (n < 4 || b.size() < n) return false;
    const std::uint16_t crc = crc16_modbus(std::span(b.data(), n - 2));
    return b[n - 2] == (crc & 0xFF) && b[n - 1] == (crc >> 8);
}

}  // namespace

void FrameSplitter::push(const std::uint8_t* data, std::size_t size) {
    buffer_.insert(buffer_.end(), data, data + size);
}

std::optional<std::vector<std::uint8_t>> FrameSplitter::next(bool flush) {
    while (!buffer_.empty()) {
        bool need_more = false;
        std::size_t found = 0;
        if (buffer_.size() < 2) {
            need_more = true;
        } else {
            const std::uint8_t fc = buffer_[1];
            std::vector<std::size_t> lengths;
            bool scan = false;
            if (fc & 0x80) {
                lengths = {5};  // exception answer
            } else if (fc >= 1 && fc <= 4) {
                lengths = {8};  // request; the answer's length needs its byte count
                if (buffer_.size() >= 3) {
                    lengths.push_back(5u + buffer_[2]);
                } else {
                    need_more = true;
                }
            } else if (fc == 5 || fc == 6) {
                lengths = {8};
            } else if (fc == 15 || fc == 16) {
                lengths = {8};  // answer; the request's length needs its byte count
                if (buffer_.size() >= 7) {
                    lengths.push_back(9u + buffer_[6]);
                } else {
                    need_more = true;
                }
            } else {
                scan = true;
            }
            if (scan) {
                const std::size_t top = std::min(buffer_.size(), kMaxFrame);
                for (std::size_t n = 4; n <= top && found == 0; ++n) {
                    if (crc_ok(buffer_, n)) found = n;
                }
                if (found == 0 && buffer_.size() < kMaxFrame) need_more = true;
            } else {
                std::sort(lengths.begin(), lengths.end());
                for (std::size_t n : lengths) {
                    if (buffer_.size() < n) {
                        need_more = true;
                        break;
                    }
                    if (crc_ok(buffer_, n)) {
                        found = n;
                        break;
                    }
                }
            }
        }
        if (found != 0) {
            std::vector<std::uint8_t> frame(buffer_.begin(),
                                            buffer_.begin() + static_cast<std::ptrdiff_t>(found));
            buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(found));
            return frame;
        }
        if (need_more && !flush) return std::nullopt;
        buffer_.erase(buffer_.begin());  // no frame starts here
    }
    return std::nullopt;
}

}  // namespace rtuscope::sim
