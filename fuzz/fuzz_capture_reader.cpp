// libFuzzer target: the capture and hex-log readers (body in targets.hpp).
#include "targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    rtuscope::fuzz::capture_reader(data, size);
    return 0;
}
