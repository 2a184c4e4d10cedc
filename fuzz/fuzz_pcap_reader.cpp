// libFuzzer target: pcap and pcapng files (body in targets.hpp).
#include "targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    rtuscope::fuzz::pcap_reader(data, size);
    return 0;
}
