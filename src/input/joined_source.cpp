#include "input/joined_source.hpp"

#include <fmt/format.h>
#include <glob.h>
#include <sys/stat.h>

#include "framing/line_settings.hpp"

namespace rtuscope {
namespace {

bool has_glob_characters(const std::string& text) {
    return text.find_first_of("*?[") != std::string::npos;
}

std::string time_text(Nanos time) {
    return fmt::format("{}.{:09}", floor_div(time, kNanosPerSecond), floor_mod(time, kNanosPerSecond));
}

class JoinedSource final : public ChunkSource {
  public:
    JoinedSource(std::vector<std::string> paths, InputFormat format, PcapOptions pcap,
                 std::unique_ptr<ChunkSource> first)
        : paths_(std::move(paths)), format_(format), pcap_(std::move(pcap)), current_(std::move(first)) {
        info_ = current_->info();
        info_.name = fmt::format("{} ... {} ({} files)", paths_.front(), paths_.back(), paths_.size());
    }

    [[nodiscard]] const SourceInfo& info() const override { return info_; }

    Result<bool> next(Chunk& out) override {
        for (;;) {
            Result<bool> more = current_->next(out);
            if (!more) return more;
            if (*more) {
                if (!checked_first_ && has_time(out.time)) {
                    checked_first_ = true;
                    if (Status s = check_order(out.time); !s) return s.error();
                }
                if (has_time(out.time)) last_time_ = out.time;
                return true;
            }
            if (index_ + 1 >= paths_.size()) return false;
            take_remarks();
            ++index_;
            Status opened = open_next();
            if (!opened) return opened.error();
        }
    }

    [[nodiscard]] std::vector<std::string> remarks() const override {
        std::vector<std::string> all = remarks_;
        for (const std::string& remark : current_->remarks()) {
            all.push_back(fmt::format("{}: {}", paths_[index_], remark));
        }
        return all;
    }

    [[nodiscard]] bool ended_by_stop() const override { return current_->ended_by_stop(); }

  private:
    void take_remarks() {
        for (const std::string& remark : current_->remarks()) {
            remarks_.push_back(fmt::format("{}: {}", paths_[index_], remark));
        }
    }

    Status open_next() {
        const std::string& path = paths_[index_];
        auto opened = open_source(path, format_, pcap_);
        if (!opened) return opened.error();
        const SourceInfo& next = (*opened)->info();
        const SourceInfo& first = info_;
        if (next.format != first.format) {
            return Error{fmt::format("is a {} file, {} a {}: files read as one stream are of one "
                                     "format",
                                     next.format, paths_.front(), first.format),
                         path};
        }
        if (next.line && first.line && (next.line->baud != first.line->baud ||
                                        next.line->format() != first.line->format())) {
            return Error{fmt::format("line settings {} {} differ from {}'s {} {}", next.line->baud,
                                     next.line->format(), paths_.front(), first.line->baud,
                                     first.line->format()),
                         path};
        }
        current_ = std::move(*opened);
        checked_first_ = false;
        return ok_status();
    }

    Status check_order(Nanos first_time) const {
        if (index_ == 0 || !has_time(last_time_) || first_time >= last_time_) return ok_status();
        return Error{fmt::format("starts at {}, before {} ends (at {}): give the files in time order",
                                 time_text(first_time), paths_[index_ - 1], time_text(last_time_)),
                     paths_[index_]};
    }

    std::vector<std::string> paths_;
    InputFormat format_;
    PcapOptions pcap_;
    std::unique_ptr<ChunkSource> current_;
    std::size_t index_ = 0;
    SourceInfo info_;
    Nanos last_time_ = kNoTime;
    bool checked_first_ = false;
    std::vector<std::string> remarks_;
};

}  // namespace

Result<std::vector<std::string>> expand_inputs(const std::vector<std::string>& arguments) {
    std::vector<std::string> paths;
    for (const std::string& argument : arguments) {
        struct stat st {};
        if (argument == "-" || !has_glob_characters(argument) || ::stat(argument.c_str(), &st) == 0) {
            paths.push_back(argument);
            continue;
        }
        glob_t found{};
        const int result = ::glob(argument.c_str(), 0, nullptr, &found);
        if (result == GLOB_NOMATCH) {
            globfree(&found);
            return Error{"no file matches this pattern", argument};
        }
        if (result != 0) {
            globfree(&found);
            return Error{"cannot read the directory of this pattern", argument};
        }
        for (std::size_t i = 0; i < found.gl_pathc; ++i) paths.emplace_back(found.gl_pathv[i]);
        globfree(&found);
    }
    return paths;
}

Result<std::unique_ptr<ChunkSource>> open_joined(const std::vector<std::string>& paths,
                                                 InputFormat format, const PcapOptions& pcap) {
    if (paths.empty()) return Error{"no input file"};
    auto first = open_source(paths.front(), format, pcap);
    if (!first || paths.size() == 1) return first;
    return std::unique_ptr<ChunkSource>(
        std::make_unique<JoinedSource>(paths, format, pcap, std::move(*first)));
}

}  // namespace rtuscope
