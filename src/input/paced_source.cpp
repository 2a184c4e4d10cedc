#include "input/paced_source.hpp"

#include <chrono>
#include <thread>
#include <utility>

namespace rtuscope {
namespace {

Nanos steady_now() { return clock_ns(CLOCK_MONOTONIC); }

class PacedSource final : public ChunkSource {
  public:
    PacedSource(std::unique_ptr<ChunkSource> source, double speed, Nanos tick)
        : source_(std::move(source)), speed_(speed), tick_(tick) {}

    [[nodiscard]] const SourceInfo& info() const override { return source_->info(); }
    [[nodiscard]] std::vector<std::string> remarks() const override { return source_->remarks(); }
    [[nodiscard]] bool ended_by_stop() const override { return source_->ended_by_stop(); }

    Result<bool> next(Chunk& out) override {
        if (!held_) {
            Result<bool> more = source_->next(chunk_);
            if (!more.ok() || !*more) return more;
            held_ = true;
        }
        if (has_time(chunk_.time) && !chunk_.bytes.empty()) {
            if (!has_time(first_time_)) {
                first_time_ = chunk_.time;
                wall_start_ = steady_now();
            }
            const Nanos due = wall_start_ + static_cast<Nanos>(
                                                static_cast<double>(chunk_.time - first_time_) / speed_);
            const Nanos wait = due - steady_now();
            if (wait > 0) {
                std::this_thread::sleep_for(std::chrono::nanoseconds(std::min(wait, tick_)));
                if (wait > tick_) {
                    // Nothing until the capture's present time.
                    out.bytes.clear();
                    out.char_errors.clear();
                    out.time = first_time_ + static_cast<Nanos>(
                                                 static_cast<double>(steady_now() - wall_start_) *
                                                 speed_);
                    out.time = std::min(out.time, chunk_.time);
                    return true;
                }
            }
        }
        std::swap(out, chunk_);
        held_ = false;
        return true;
    }

  private:
    std::unique_ptr<ChunkSource> source_;
    double speed_;
    Nanos tick_;
    Chunk chunk_;
    bool held_ = false;
    Nanos first_time_ = kNoTime;
    Nanos wall_start_ = 0;
};

}  // namespace

std::unique_ptr<ChunkSource> pace_source(std::unique_ptr<ChunkSource> source, double speed,
                                         Nanos tick) {
    return std::make_unique<PacedSource>(std::move(source), speed, tick);
}

}  // namespace rtuscope
