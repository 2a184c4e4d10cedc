// libFuzzer target: profile files through the loader (body in targets.hpp).
#include "targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    rtuscope::fuzz::profile_loader(data, size);
    return 0;
}
