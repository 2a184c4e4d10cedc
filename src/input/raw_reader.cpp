// Raw reader: the bytes of a dump (`cat /dev/ttyUSB0 > dump.bin`) with no timing, in
// chunks of at most 4 KiB. Without times the framer can only cut by length and CRC.
#include <cstdint>
#include <memory>

#include "input/readers.hpp"

namespace rtuscope::detail {
namespace {

constexpr std::size_t kRawChunkBytes = 4096;

class RawReader final : public ChunkSource {
  public:
    explicit RawReader(std::unique_ptr<InputBuffer> in) : in_(std::move(in)) {
        info_.name = in_->name();
        info_.format = "raw";
    }

    [[nodiscard]] const SourceInfo& info() const override { return info_; }

    Result<bool> next(Chunk& out) override {
        std::string_view block;
        Result<bool> more = in_->next_block(kRawChunkBytes, block);
        if (!more || !*more) return more;
        out.time = kNoTime;
        out.channel.clear();
        const auto* first = reinterpret_cast<const std::uint8_t*>(block.data());
        out.bytes.assign(first, first + block.size());
        out.source_line = 0;
        return true;
    }

  private:
    std::unique_ptr<InputBuffer> in_;
    SourceInfo info_;
};

}  // namespace

std::unique_ptr<ChunkSource> make_raw_reader(std::unique_ptr<InputBuffer> in) {
    return std::make_unique<RawReader>(std::move(in));
}

}  // namespace rtuscope::detail
