// libFuzzer target: bytes from the line through the whole chain into every sink (body in
// targets.hpp).
#include "targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    rtuscope::fuzz::pipeline(data, size);
    return 0;
}
