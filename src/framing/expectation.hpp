// The framer asks the pairing stage which answer the bus is waiting for, so that bytes
// that read two ways (a request followed by 00 also passes as a 9-byte FC03 answer) are
// read the way the request/answer sequence says.
#pragma once

#include <cstdint>
#include <span>

#include "util/time.hpp"

namespace rtuscope {

struct AwaitedAnswer {
    std::uint8_t slave = 0;
    std::uint8_t function = 0;
    std::span<const std::uint8_t> request;  // the whole request frame
};

class AnswerExpectation {
  public:
    virtual ~AnswerExpectation() = default;
    // The request still waiting for its answer at time `at` (kNoTime when the input has
    // no timing), or nullptr.
    [[nodiscard]] virtual const AwaitedAnswer* awaited(Nanos at) const = 0;
};

}  // namespace rtuscope
