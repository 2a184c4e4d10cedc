// The passive framer. See framer.hpp for why gaps alone cannot delimit frames.
//
// Bytes wait in a buffer until the first undecided byte can be decided:
//  1. At the first byte, every reading the function code allows (request, answer,
//     exception) gives a length; a length whose CRC checks is a frame. When several do
//     (a request followed by 00 also passes as a 9-byte FC03 answer), the reading the
//     request/answer sequence expects wins, then the one followed by a gap, then the
//     shorter. Function codes whose length no field gives are found by the CRC over
//     the possible lengths, bounded by the next gap where the input has timing; a
//     length with a frame of known length inside is a chance, not a frame.
//  2. Otherwise the bytes up to the next position where a frame starts are cut at gaps;
//     a piece that exactly fits a frame's shape is an invalid frame (CRC wrong), a piece
//     that is cut short between two gaps is a truncated frame, the rest is noise.
#include "framing/framer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <functional>
#include <limits>
#include <span>
#include <vector>

namespace rtuscope {
namespace {

// The stray bytes an RS-485 driver may leave around a frame as it switches.
constexpr std::size_t kMaxJunk = 2;
// Line noise between transactions that stays apart from a damaged frame after it, by a
// wider margin than junk.
constexpr std::size_t kMaxNoise = 3;

// How many damaged frames may lie between a damaged frame's reading and the next frame
// or proven silence for where it ends to count (a request and its answer, both hit).
constexpr int kMaxChain = 2;

// A request's word after its address (a quantity, a coil's value): its bytes 4 and 5, of
// at least 6.
std::uint16_t word_of(std::span<const std::uint8_t> request) {
    return static_cast<std::uint16_t>((request[4] << 8U) | request[5]);
}

// How many bits two bytes or words differ in: a bit error flips one.
int bits_apart(unsigned a, unsigned b) {
    return std::popcount(a ^ b);
}

// A slave, a function and the quantity asked, as the key of Framer::answer_counts_.
std::uint32_t answer_count_key(std::uint8_t slave, std::uint8_t function, unsigned asked) {
    return (std::uint32_t{slave} << 24U) | (std::uint32_t{function} << 16U) | (asked & 0xFFFFU);
}

// A frame's slave and function, as an index of Framer::disallowed_words_seen_.
std::size_t slave_function(std::span<const std::uint8_t> head) {
    return (std::size_t{head[0]} << 7U) | (head[1] & 0x7FU);
}

// A gap before the first byte of the input or of a new channel: always a boundary.
constexpr Nanos kBoundary = std::numeric_limits<Nanos>::max();

// The items of `list`, in order of their buffer index (`index_of`), that lie within the
// frame of `length` bytes at `at`: found by search, as a list can hold one a byte.
template <class T, class IndexOf = std::identity>
std::span<const T> within_frame(const std::vector<T>& list, std::size_t at, std::size_t length,
                                IndexOf index_of = {}) {
    const auto first = std::ranges::lower_bound(list, at, {}, index_of);
    return {first, std::ranges::lower_bound(first, list.end(), at + length, {}, index_of)};
}

// A silence the input measured (a boundary or an unknown gap is none).
bool is_measured(Nanos gap) {
    return gap != kNoTime && gap != kBoundary;
}

Reading reading_for(Role role, std::uint8_t function) {
    if (role == Role::request) return Reading::request;
    return (function & 0x80U) ? Reading::exception : Reading::response;
}

// The CRC as it should be and as it came, in wire order (low byte first).
void add_crc_note(Frame& frame) {
    const CrcCheck& crc = frame.crc;
    if (crc.status != CrcStatus::bad && crc.status != CrcStatus::swapped) return;
    const bool bad = crc.status == CrcStatus::bad;
    frame.notes.add(bad ? note_id::crc_mismatch : note_id::crc_swapped,
                    fmt::format("{} (expected {:02X} {:02X}, got {:02X} {:02X})",
                                bad ? "CRC BAD" : "CRC bytes swapped", crc.expected & 0xFFU,
                                crc.expected >> 8, crc.received & 0xFFU, crc.received >> 8));
}

// How well a reading's CRC checks, for the choice between readings: right beats swapped
// beats wrong.
int crc_rank(CrcStatus status) {
    return status == CrcStatus::ok ? 2 : status == CrcStatus::swapped ? 1 : 0;
}

// The reading at the start of `head` when the CRCs alone settle it: each reading's length
// is in hand (or it has none) and exactly one checks best. Most positions are like that;
// the rest go through attempt_at's general rules.
struct PlainReading {
    bool decided = false;  // false: the general rules must decide
    bool found = false;    // decided: a reading checks (else no frame starts here)
    // found: both readings are these same bytes (echoed answers: FC05, FC06, ...), so
    // `role` is not settled: the request/answer order decides.
    bool either = false;
    std::size_t length = 0;
    Role role = Role::request;
    std::uint16_t expected_crc = 0;  // of its bytes before the last two; the caller checks
};

PlainReading plain_reading(std::span<const std::uint8_t> head, const FrameLengths& lengths) {
    PlainReading result;
    const FrameLength& request = lengths.request;
    const FrameLength& response = lengths.response;
    const bool request_fits = request.fixed_within(head.size());
    const bool response_fits = response.fixed_within(head.size());
    if ((!request_fits && request.kind != FrameLength::Kind::none) ||
        (!response_fits && response.kind != FrameLength::Kind::none) ||
        (!request_fits && !response_fits)) {
        return result;  // undecided: attempt_at's general rules take over
    }
    result.decided = true;
    // One reading fits, or both are the same bytes: one CRC settles it.
    const bool same_bytes = request_fits && response_fits && request.bytes == response.bytes;
    if (same_bytes || !request_fits || !response_fits) {
        const Role role = request_fits ? Role::request : Role::response;
        const std::size_t n = lengths.of(role).bytes;
        const std::uint16_t crc = crc16_modbus(head.first(n - 2));
        if (crc_check_of(head.first(n), crc).status != CrcStatus::bad) {
            result = {true, true, same_bytes, n, role, crc};
        }
        return result;
    }
    // One pass for both: the CRC of the shorter reading is where the longer one's begins.
    const bool request_shorter = request.bytes < response.bytes;
    const std::size_t shorter = request_shorter ? request.bytes : response.bytes;
    const std::size_t longer = request_shorter ? response.bytes : request.bytes;
    const std::uint16_t short_crc = crc16_modbus(head.first(shorter - 2));
    const std::uint16_t long_crc =
        crc16_modbus_update(short_crc, head.subspan(shorter - 2, longer - shorter));
    const int short_rank = crc_rank(crc_check_of(head.first(shorter), short_crc).status);
    const int long_rank = crc_rank(crc_check_of(head.first(longer), long_crc).status);
    if (short_rank == long_rank) {
        // Neither checks: no frame. Both equally: order and silences decide (attempt_at).
        result.decided = short_rank == 0;
        return result;
    }
    const bool short_wins = short_rank > long_rank;
    result.found = true;
    result.length = short_wins ? shorter : longer;
    result.role = short_wins == request_shorter ? Role::request : Role::response;
    result.expected_crc = short_wins ? short_crc : long_crc;
    return result;
}

double in_ms(Nanos t) {
    return static_cast<double>(t) / 1e6;
}

}  // namespace

Framer::Framer(const FramerOptions& options, Emit emit)
    : options_(options),
      emit_(std::move(emit)),
      char_time_(options.line.char_time()),
      t15_(options.line.t15()),
      t35_(options.line.t35()) {}

std::uint32_t Framer::channel_number(const std::string& name) {
    if (auto it = channel_numbers_.find(name); it != channel_numbers_.end()) return it->second;
    if (channels_.size() >= channels_limit_) forget_unused_channels();
    const auto number = static_cast<std::uint32_t>(channels_.size());
    channels_.push_back(name);
    channel_numbers_.emplace(name, number);
    return number;
}

void Framer::forget_unused_channels() {
    // Only the buffered chunks' channels are still needed. A tap has two; a crafted
    // capture may name millions, which must neither grow the table without end nor
    // outnumber the pieces' channel index (a frame would be given another channel's name).
    constexpr std::uint32_t kUnused = ~std::uint32_t{0};
    std::vector<std::uint32_t> renumbered(channels_.size(), kUnused);
    std::vector<std::string> kept;
    for (Piece& piece : pieces_) {
        std::uint32_t& to = renumbered[piece.channel];
        if (to == kUnused) {
            to = static_cast<std::uint32_t>(kept.size());
            kept.push_back(std::move(channels_[piece.channel]));
        }
        piece.channel = to;
    }
    channels_ = std::move(kept);
    channel_numbers_.clear();
    for (std::uint32_t i = 0; i < channels_.size(); ++i) channel_numbers_.emplace(channels_[i], i);
    channels_limit_ = 2 * channels_.size() + kChannelsKept;
}

void Framer::push(const Chunk& chunk) {
    if (chunk.bytes.empty()) return;
    // The stream so far cannot go on into a frame that stands on its own, or into a packet.
    if ((chunk.whole_frame || chunk.packet) && pos_ < bytes_.size()) decide(true);
    if (chunk.transport == Transport::tcp) {
        emit_modbus_tcp(chunk);
        return;
    }
    if (chunk.whole_frame) {
        emit_chunk_as_frame(chunk);
        return;
    }

    // Channel of this chunk; a change of channel is a frame boundary.
    if (channels_.empty() || channels_[last_channel_] != chunk.channel) {
        last_channel_ = channel_number(chunk.channel);
    }
    const std::uint32_t channel = last_channel_;
    const bool channel_changed =
        !pieces_.empty() && pos_ < bytes_.size() && pieces_.back().channel != channel;

    // The chunk's time is when its last byte arrived; earlier bytes are placed back to
    // back before it, but never before the previous byte (adapters deliver late). Where
    // the time is the first byte's start (a hex log's line), the bytes follow it back to
    // back, after the previous byte if the stamp is earlier (a log's coarse clock).
    const auto n = static_cast<Nanos>(chunk.bytes.size());
    const bool start_stamped = options_.chunk_time_is_start;
    // A capture whose clock jumps back (a hand-edited file, a reset clock) cannot say how
    // long the line was quiet: no gap to measure, no turnaround, and the frame says why.
    const bool clock_back =
        has_time(chunk.time) && has_time(last_stamp_) && chunk.time < last_stamp_;
    Nanos first_start = kNoTime;
    Nanos last_end = kNoTime;
    Nanos gap = kNoTime;
    if (has_time(chunk.time)) {
        first_start = start_stamped ? chunk.time : chunk.time - n * char_time_;
        last_end = start_stamped ? chunk.time + n * char_time_ : chunk.time;
        if (has_time(last_end_)) {
            gap = std::max<Nanos>(0, first_start - last_end_);
            if (first_start < last_end_ && !clock_back) {
                if (chunk.packet && !chunk.time_estimated) {
                    // A packet's stamp is its first byte's start, as the capture measured
                    // it: kept, though the line settings end the bytes before it later.
                    gap = kNoTime;
                } else {
                    if (start_stamped) {
                        // A log's clock too coarse to place the line (stamped before the
                        // bytes before it ended): no silence measured, so no turnaround
                        // made up of zero.
                        last_end += last_end_ - first_start;
                        gap = kNoTime;
                    }
                    first_start = last_end_;
                }
            }
        }
    }
    // Placed after the bytes before it, or after bytes placed so: no silence measured.
    if (chunk.time_estimated || last_end_estimated()) gap = kNoTime;
    if (!seen_bytes_ || channel_changed) gap = kBoundary;
    // After a frame that stood on its own the stream starts afresh, silence measured or not.
    if (after_whole_frame_ && !is_measured(gap)) gap = kBoundary;
    if (clock_back) {
        time_jumps_.emplace_back(bytes_.size(), last_stamp_ - chunk.time);
        gap = kBoundary;
    }

    Piece piece;
    piece.first = base_ + bytes_.size();
    piece.end = piece.first + chunk.bytes.size();
    piece.first_start = first_start;
    if (has_time(chunk.time)) {
        piece.step = (last_end - first_start) / n;
        piece.step_remainder = (last_end - first_start) % n;
    }
    piece.time = last_end;
    piece.gap = gap;
    piece.line = chunk.source_line;
    piece.channel = channel;
    // A log's stamp says when a line was seen, never when each byte ended.
    piece.exact = chunk.bytes.size() == 1 && previous_chunk_single_ && !start_stamped;
    piece.starts_frame = chunk.packet;
    packet_first_ = chunk.packet ? piece.first : kNoIndex;
    pieces_.push_back(piece);
    if (ends_frame(gap) || piece.starts_frame) frame_gaps_.push_back(piece.first);
    const auto errors_before = static_cast<std::ptrdiff_t>(char_errors_.size());
    for (const std::uint32_t offset : chunk.char_errors) {
        if (offset < chunk.bytes.size()) char_errors_.push_back(bytes_.size() + offset);
    }
    // Kept in order, so that a frame finds its own by binary search.
    std::sort(char_errors_.begin() + errors_before, char_errors_.end());
    bytes_.insert(bytes_.end(), chunk.bytes.begin(), chunk.bytes.end());
    if (has_time(chunk.time)) {
        last_end_ = last_end;
        last_stamp_ = chunk.time;
    }
    previous_chunk_single_ = chunk.bytes.size() == 1;
    seen_bytes_ = true;
    after_whole_frame_ = false;
    if (chunk.packet && chunk.bytes_not_captured != 0) {
        // Nothing can follow the cut in this packet: decided now, its cut end noted.
        not_captured_ = chunk.bytes_not_captured;
        decide(true);
        not_captured_ = 0;
        return;
    }
    decide(false);
}

void Framer::idle(Nanos now, Nanos idle_margin) {
    if (pos_ >= bytes_.size() || !has_time(last_end_) || !has_time(now)) return;
    if (now - last_end_ < t35_ + idle_margin) return;
    decide(true);
}

void Framer::finish(bool stopped) {
    stopped_ = stopped;
    decide(true);
}

const Framer::Piece& Framer::find_piece(std::size_t at) const {
    const std::uint64_t index = base_ + at;
    // Most lookups are just after the previous one.
    std::size_t i = piece_hint_ < pieces_.size() ? piece_hint_ : 0;
    if (pieces_[i].first > index) i = 0;
    for (std::size_t steps = 0; i + 1 < pieces_.size() && pieces_[i + 1].first <= index; ++i) {
        if (++steps == 4) {
            auto it = std::upper_bound(
                pieces_.begin() + static_cast<std::ptrdiff_t>(i), pieces_.end(), index,
                [](std::uint64_t value, const Piece& p) { return value < p.first; });
            i = static_cast<std::size_t>(it - pieces_.begin()) - 1;
            break;
        }
    }
    piece_hint_ = i;
    return pieces_[i];
}

Nanos Framer::byte_end(std::size_t at) const {
    return byte_end(piece_of(at), at);
}

Nanos Framer::byte_end(const Piece& p, std::size_t at) const {
    if (!has_time(p.time)) return kNoTime;
    // Spread evenly over the chunk, its last byte ending at the chunk's time:
    // first_start + span * (i + 1) / n. With span = step * n + step_remainder that is
    // step * (i + 1) + step_remainder * (i + 1) / n, whose division is of numbers below
    // n * n, not of nanoseconds: a 64-bit division per frame is a measurable part of a
    // decode's time, a 32-bit one is several times cheaper.
    const auto i = static_cast<Nanos>(base_ + at - p.first);
    if (i == 0) return p.first_start + p.step;
    const auto n = static_cast<Nanos>(p.end - p.first);
    if (i + 1 == n) return p.time;
    const Nanos part = p.step_remainder * (i + 1);
    // A chunk placed back to back before its time spans exactly n characters: no
    // remainder, no division (most chunks of a capture).
    if (part == 0) return p.first_start + p.step * (i + 1);
    const Nanos extra =
        n < (1 << 15) ? static_cast<std::int32_t>(part) / static_cast<std::int32_t>(n) : part / n;
    return p.first_start + p.step * (i + 1) + extra;
}

Nanos Framer::gap_at(std::size_t at) const {
    return gap_at(piece_of(at), at);
}

Nanos Framer::gap_at(const Piece& p, std::size_t at) const {
    return p.first == base_ + at ? p.gap : kNoTime;
}

bool Framer::gap_before(std::size_t at) const {
    if (at >= bytes_.size()) return false;
    const Piece& piece = piece_of(at);
    if (piece.first != base_ + at) return false;
    return piece.starts_frame || ends_frame(piece.gap);
}

std::size_t Framer::gap_after(std::size_t after, std::size_t limit) const {
    if (after + 1 >= limit) return limit;
    const auto next = std::ranges::upper_bound(frame_gaps_, base_ + after);
    if (next == frame_gaps_.end()) return limit;
    return std::min(static_cast<std::size_t>(*next - base_), limit);
}

std::size_t Framer::next_gap(std::size_t after) const {
    // Only the next kMaxAdu bytes matter to the callers (a frame is never longer).
    const std::size_t limit = std::min(bytes_.size(), after + kMaxAdu + 1);
    const std::size_t found = gap_after(after, limit);
    return found < limit ? found : bytes_.size();
}

Framer::Attempt Framer::attempt_at(std::size_t at, bool at_end) const {
    Attempt none;
    const std::size_t avail = bytes_.size() - at;
    if (avail < 2) {
        none.outcome = at_end ? Outcome::no_frame : Outcome::need_more;
        none.wanted = 2;
        return none;
    }
    const auto head = std::span(bytes_).subspan(at, std::min(avail, kMaxAdu));
    const std::uint8_t function = head[1];
    const ProtocolRules& rules = *options_.rules;

    const FrameLengths lengths = rules.frame_lengths(head);
    if (const auto plain = plain_reading(head, lengths); plain.decided) {
        if (!plain.found) return none;
        Attempt frame;
        frame.outcome = Outcome::frame;
        frame.length = plain.length;
        const Role role = plain.either && expects_answer_at(at, head) ? Role::response : plain.role;
        frame.reading = reading_for(role, function);
        frame.crc = crc_check_of(head.first(plain.length), plain.expected_crc);
        return with_delimiter(frame, at, at_end);
    }

    // Only asked when two readings fit or the length was searched, so worked out on
    // first use.
    enum class Preference : std::uint8_t { unknown, request, response };
    Preference preference = Preference::unknown;
    auto prefers_response = [&] {
        if (preference == Preference::unknown) {
            preference = expects_answer_at(at, head) ? Preference::response : Preference::request;
        }
        return preference == Preference::response;
    };

    // Bytes (from `at`) a reading still waits for; 0: none waits.
    std::size_t wanted = 0;
    auto wait_for = [&](std::size_t bytes) {
        wanted = wanted == 0 ? bytes : std::min(wanted, bytes);
    };
    bool searched = false;
    Attempt best;
    // A frame and the 00 after it check as a frame one byte longer (the CRC of a frame
    // and its CRC's low byte is 00 and its high byte). Where the 00 starts the next frame
    // (or a silence the batching cannot have made) and nothing follows the longer reading,
    // the shorter reading is the frame; bytes still to come may tell.
    bool null_tail_pending = false;
    auto null_tail = [&](const Attempt& longer, const Attempt& shorter) {
        if (longer.length != shorter.length + 1 || bytes_[at + shorter.length] != 0 ||
            what_follows(at + shorter.length, at_end, true) != Follows::boundary) {
            return false;
        }
        const Follows after_longer = what_follows(at + longer.length, at_end);
        null_tail_pending = null_tail_pending || after_longer == Follows::unknown_yet;
        return after_longer == Follows::nothing;
    };
    auto better = [&](const Attempt& a, const Attempt& b) {
        if (crc_rank(a.crc.status) != crc_rank(b.crc.status)) {
            return crc_rank(a.crc.status) > crc_rank(b.crc.status);
        }
        if (null_tail(b, a)) return true;
        if (null_tail(a, b)) return false;
        const bool a_answer = a.reading != Reading::request;
        if (a_answer != (b.reading != Reading::request)) return a_answer == prefers_response();
        const bool a_gap = followed_by_gap(at + a.length, at_end);
        if (a_gap != followed_by_gap(at + b.length, at_end)) return a_gap;
        return a.length < b.length;
    };

    for (const Role role : {Role::request, Role::response}) {
        const FrameLength& length = lengths.of(role);
        Attempt candidate;
        candidate.outcome = Outcome::frame;
        candidate.reading = reading_for(role, function);
        switch (length.kind) {
            case FrameLength::Kind::none:
                continue;
            case FrameLength::Kind::need_more:
                // More bytes would tell the length (head is all that is buffered).
                if (!at_end && head.size() < kMaxAdu) wait_for(length.bytes);
                continue;
            case FrameLength::Kind::fixed: {
                if (length.bytes < kMinAdu) continue;
                if (length.bytes > avail) {
                    if (!at_end) wait_for(length.bytes);
                    continue;
                }
                candidate.length = length.bytes;
                candidate.crc = check_crc(head.first(length.bytes));
                if (candidate.crc.status == CrcStatus::bad) continue;
                candidate.delimiter = Delimiter::length_crc;
                break;
            }
            case FrameLength::Kind::search: {
                // A code one reading searches, the other does too, and the search does not
                // depend on the reading: the request reading's search decided it.
                if (searched) continue;
                searched = true;
                const Search found = search_length(at, at_end, true);
                if (found.pending) wait_for(avail + 1);  // a gap may end the search
                if (found.length == 0) continue;
                candidate.length = found.length;
                candidate.crc = check_crc(head.first(found.length));
                candidate.delimiter = Delimiter::crc_search;
                // Order, not shape, tells which way these go.
                candidate.reading =
                    prefers_response() ? reading_for(Role::response, function) : Reading::request;
                break;
            }
        }
        if (best.outcome != Outcome::frame || better(candidate, best)) {
            best = candidate;
        }
    }
    if (null_tail_pending) wait_for(avail + 1);

    if (wanted != 0) {
        none.outcome = Outcome::need_more;
        none.wanted = wanted;
        return none;
    }
    if (best.outcome != Outcome::frame) return none;
    if (best.delimiter != Delimiter::length_crc) return best;
    return with_delimiter(best, at, at_end);
}

bool Framer::expects_answer_at(std::size_t at, std::span<const std::uint8_t> head) const {
    const std::string& channel = channels_[piece_of(at).channel];
    if (!channel.empty() && !options_.request_channel.empty()) {
        return channel != options_.request_channel;
    }
    const Nanos at_end_time = byte_end(at);
    if (!awaits_answer(head, at_end_time)) return false;
    // The same request sent again (a master's retry) is not an answer, unless answers to
    // this function repeat the request anyway.
    const auto& req = options_.expectation->awaited(at_end_time)->request;
    return options_.rules->answer_is_echo(head[0], head[1]) || req.size() > bytes_.size() - at ||
           !std::equal(req.begin(), req.end(), head.begin());
}

Framer::Attempt Framer::with_delimiter(Attempt frame, std::size_t at, bool at_end) const {
    const std::size_t end = at + frame.length;
    if (followed_by_gap(end, at_end)) {
        frame.delimiter = Delimiter::gap;
    } else if (end == bytes_.size()) {
        frame.delimiter = Delimiter::end_of_input;
    } else {
        frame.delimiter = Delimiter::length_crc;
    }
    return frame;
}

bool Framer::followed_by_gap(std::size_t end, bool at_end) const {
    return end == bytes_.size() ? at_end : gap_before(end);
}

Framer::Search Framer::search_length(std::size_t at, bool at_end, bool confirm) const {
    // CRC over each possible length, bounded by the next gap where there is timing. By
    // chance one length in 65536 passes, so a hit must also be followed by a silence,
    // the end of the input, or another frame: random bytes rarely manage both.
    Search result;
    const std::size_t avail = bytes_.size() - at;
    const auto head = std::span(bytes_).subspan(at, std::min(avail, kMaxAdu));
    const std::size_t bound = std::min(next_gap(at) - at, head.size());
    if (bound < kMinAdu) {
        result.pending = !at_end && bound == avail;
        return result;
    }
    // Whether a frame of n bytes whose CRC checks ends the search.
    auto ends_search = [&](std::size_t n) {
        const Follows follows = confirm ? what_follows(at + n, at_end) : Follows::boundary;
        // Without silences to bound it (a raw dump) the search may reach across real
        // frames, and the one length in 65536 that passes by chance is then often one at
        // which another frame starts. A frame of known length inside says that is what
        // happened: no frame starts here, and a longer length would hold it too.
        if (follows == Follows::boundary && confirm && holds_known_frame(at, n)) return true;
        if (follows == Follows::boundary) result.length = n;
        if (follows == Follows::unknown_yet) result.pending = true;
        return follows != Follows::nothing;
    };
    // Through garbage every byte starts a search over the same bytes: the index answers
    // them all from one pass over the bytes (crc_end_index.hpp).
    if (crc_ends_.find(bytes_, at, kMinAdu, bound, ends_search)) return result;
    result.pending = !at_end && bound == avail && avail < kMaxAdu;
    return result;
}

bool Framer::holds_known_frame(std::size_t at, std::size_t n) const {
    for (std::size_t inner = at + 1; inner + kMinAdu <= at + n; ++inner) {
        const auto head = std::span(bytes_).subspan(inner, at + n - inner);
        const FrameLengths lengths = options_.rules->frame_lengths(head);
        for (const Role role : {Role::request, Role::response}) {
            const FrameLength& length = lengths.of(role);
            if (length.fixed_within(head.size()) &&
                check_crc(head.first(length.bytes)).status == CrcStatus::ok) {
                return true;
            }
        }
    }
    return false;
}

Framer::Follows Framer::what_follows(std::size_t end, bool at_end, bool proven) const {
    if (end == bytes_.size()) return at_end ? Follows::boundary : Follows::unknown_yet;
    if (proven ? proven_gap_before(end) : gap_before(end)) return Follows::boundary;
    const std::size_t avail = bytes_.size() - end;
    if (avail < 2) return at_end ? Follows::nothing : Follows::unknown_yet;
    const auto head = std::span(bytes_).subspan(end, std::min(avail, kMaxAdu));
    bool unknown_yet = false;
    const FrameLengths lengths = options_.rules->frame_lengths(head);
    for (const Role role : {Role::request, Role::response}) {
        const FrameLength& length = lengths.of(role);
        if (length.kind == FrameLength::Kind::fixed && length.bytes >= kMinAdu) {
            if (length.bytes > avail) {
                unknown_yet = unknown_yet || !at_end;
            } else if (check_crc(head.first(length.bytes)).status != CrcStatus::bad) {
                return Follows::boundary;
            }
        } else if (length.kind == FrameLength::Kind::need_more) {
            unknown_yet = unknown_yet || (!at_end && head.size() < kMaxAdu);
        } else if (length.kind == FrameLength::Kind::search) {
            const Search next = search_length(end, at_end, false);
            if (next.length != 0) return Follows::boundary;
            unknown_yet = unknown_yet || next.pending;
        }
    }
    return unknown_yet ? Follows::unknown_yet : Follows::nothing;
}

void Framer::decide(bool at_end) {
    while (pos_ < bytes_.size()) {
        // The last attempt here waits for more bytes than have come: nothing can change
        // before they have (slow lines hand frames over in many small chunks).
        if (!at_end && base_ + pos_ == waiting_at_ && bytes_.size() - pos_ < waiting_for_) break;
        // Through garbage that comes a byte at a time, the position stays put while the
        // scan for the next frame waits ahead of it (scan_hint_): it is tried once, not at
        // every byte.
        if (at_end || scan_hint_ <= pos_) {
            const Attempt here = attempt_at(pos_, at_end);
            if (here.outcome == Outcome::need_more) {
                waiting_at_ = base_ + pos_;
                waiting_for_ = here.wanted;
                break;
            }
            if (here.outcome == Outcome::frame) {
                if (here.delimiter == Delimiter::crc_search) {
                    const Note searched{note_id::unknown_length, "length found by CRC"};
                    emit(pos_, here.length, RecordClass::frame, here.reading, here.delimiter,
                         here.crc, &searched);
                } else {
                    emit(pos_, here.length, RecordClass::frame, here.reading, here.delimiter,
                         here.crc);
                }
                continue;
            }
        }

        // No frame starts here: find where the next one does.
        std::size_t resync = std::max(scan_hint_, pos_ + 1);
        bool waiting = false;
        for (; resync < bytes_.size(); ++resync) {
            const Attempt there = attempt_at(resync, at_end);
            if (there.outcome == Outcome::frame) {
                const std::optional<bool> chance = found_by_chance(there, resync, at_end);
                if (!chance) {
                    waiting = true;
                    break;
                }
                if (*chance) continue;
                break;
            }
            if (there.outcome == Outcome::need_more) {
                waiting = true;
                break;
            }
        }
        if (waiting) {
            // Long garbage must not grow the buffer without end: what lies a whole ADU
            // before the undecided position can no longer be part of a frame.
            if (resync - pos_ > 16 * kMaxAdu) {
                classify_unframed(pos_, resync - kMaxAdu, false, at_end);
            }
            // After what that emitted, which forgets the hint.
            scan_hint_ = resync;
            break;
        }
        classify_unframed(pos_, resync, resync < bytes_.size(), at_end);
    }

    // What is decided goes once it is all decided, or in batches (a front erase each):
    // 64 KiB of bytes, or 4,096 chunks, whose channel names are kept with them.
    if (pos_ == bytes_.size() || pos_ > (1U << 16) || (pieces_.size() > 4096 && pos_ > 0)) {
        const auto drop = static_cast<std::ptrdiff_t>(pos_);
        bytes_.erase(bytes_.begin(), bytes_.begin() + drop);
        crc_ends_.clear();
        base_ += pos_;
        // Chunks wholly before the new start go; the one the start falls in stays.
        std::size_t keep = 0;
        while (keep + 1 < pieces_.size() && pieces_[keep + 1].first <= base_) ++keep;
        if (bytes_.empty()) keep = pieces_.size();
        pieces_.erase(pieces_.begin(), pieces_.begin() + static_cast<std::ptrdiff_t>(keep));
        std::erase_if(frame_gaps_, [&](std::uint64_t index) { return index < base_; });
        piece_hint_ = 0;
        std::erase_if(char_errors_, [&](std::size_t index) { return index < pos_; });
        for (std::size_t& index : char_errors_) index -= pos_;
        std::erase_if(time_jumps_, [&](const auto& jump) { return jump.first < pos_; });
        for (auto& jump : time_jumps_) jump.first -= pos_;
        scan_hint_ = scan_hint_ > pos_ ? scan_hint_ - pos_ : 0;
        pos_ = 0;
    }
}

bool Framer::awaits_answer(std::span<const std::uint8_t> head, Nanos at) const {
    if (options_.expectation == nullptr || head.size() < 2) return false;
    const AwaitedAnswer* awaited = options_.expectation->awaited(at);
    return awaited != nullptr && awaited->slave == head[0] &&
           awaited->function == (head[1] & 0x7FU);
}

Reading Framer::reading_by_shape(std::span<const std::uint8_t> frame, Nanos at,
                                 bool any_length_fits_search, const std::string& channel) const {
    if (frame.size() < 2) return Reading::unknown;
    bool fits[2] = {false, false};
    const FrameLengths lengths = options_.rules->frame_lengths(frame);
    for (const Role role : {Role::request, Role::response}) {
        const FrameLength& length = lengths.of(role);
        fits[role == Role::response] =
            (length.kind == FrameLength::Kind::fixed && length.bytes == frame.size()) ||
            (any_length_fits_search && length.kind == FrameLength::Kind::search);
    }
    if (!fits[0] && !fits[1]) return Reading::unknown;
    // On a two-port tap the port the bytes came on says which way they went.
    if (!channel.empty() && !options_.request_channel.empty()) {
        return channel == options_.request_channel ? Reading::request
                                                   : reading_for(Role::response, frame[1]);
    }
    const bool prefer_response = awaits_answer(frame, at);
    if (fits[0] && fits[1]) {
        return prefer_response ? reading_for(Role::response, frame[1]) : Reading::request;
    }
    if (fits[0]) return Reading::request;
    return reading_for(Role::response, frame[1]);
}

void Framer::classify_unframed(std::size_t from, std::size_t to, bool before_frame, bool at_end) {
    const bool timed = has_time(byte_end(from));
    // The bytes a stop cut off end nowhere a frame does: no length is taken from them.
    const bool cut_at_stop = stopped_ && to == bytes_.size();
    const bool lengths_apply = seen_valid_frame_ && !cut_at_stop;
    // Before the input's first valid frame, bytes may be the tail of a frame the input
    // began in the middle of (a port opened mid-frame): no length is taken there, but for
    // damaged frames that run from the input's first byte, one after another, exactly to
    // the first valid frame, as a tail does once in many.
    bool from_input_start = !seen_valid_frame_ && before_frame && base_ + from == 0;
    std::size_t start = from;
    while (start < to) {
        const DamagedFit fit = lengths_apply ? damaged_frame(start, to, false, kMaxChain, at_end)
                               : from_input_start
                                   ? damaged_frame(start, to, true, kMaxChain, at_end)
                                   : DamagedFit{};
        // A junk byte or two before a damaged frame can read as a frame of its own: the
        // frame after them wins when its reading is much the likelier, by a wider margin
        // where it does not end where the next frame or a proven silence begins (another
        // damaged frame, its length lost, may follow it). So do three bytes of line noise,
        // before a frame that ends at the next frame, by a wider margin still.
        std::size_t junk = 0;
        for (std::size_t n = 1;
             lengths_apply && fit.length != 0 && junk == 0 && n <= kMaxNoise && start + n < to;
             ++n) {
            const DamagedFit there = damaged_frame(start + n, to, n > kMaxJunk, kMaxChain, at_end);
            const int margin = n > kMaxJunk ? 4 : there.where == 3 ? 2 : 3;
            const bool likelier =
                there.rank >= fit.rank + margin && (n <= kMaxJunk || there.where == 3);
            if (likelier) junk = n;
        }
        if (junk != 0) {
            emit(start, junk, RecordClass::noise, Reading::unknown, Delimiter::gap, {});
            start += junk;
            continue;
        }
        if (fit.length != 0) {
            // Its CRC may check after all: a frame that a longer reading's chance CRC hid.
            const CrcCheck crc = check_crc(std::span(bytes_).subspan(start, fit.length));
            emit(start, fit.length,
                 crc.status == CrcStatus::bad ? RecordClass::invalid : RecordClass::frame,
                 fit.reading,
                 gap_before(start + fit.length) ? Delimiter::gap : Delimiter::length_crc, crc);
            start += fit.length;
            continue;
        }
        from_input_start = false;
        std::size_t end = gap_after(start, to);
        // A frame whose CRC fails may begin after a few stray bytes: one that ends just
        // where the next frame or a proven silence begins. With exact timing the stray
        // bytes are a junk byte or two; batched, whatever came before the next proven
        // silence. None inside the start of a frame that the end of the input cut.
        const std::size_t search_end = options_.batching.hold == 0
                                           ? std::min(end, start + 1 + kMaxJunk)
                                           : std::min(to, start + kMaxAdu);
        for (std::size_t at = start + 1; at < search_end && lengths_apply && !fit.cut_by_end;
             ++at) {
            if (proven_gap_before(at)) break;
            if (damaged_frame(at, to, true, kMaxChain, at_end).length != 0) {
                end = std::min(end, at);
                break;
            }
        }
        if (options_.chunk_is_line) end = end_of_unframed_lines(start, end);
        const std::size_t n = end - start;
        const auto piece = std::span(bytes_).subspan(start, n);
        const bool bounded_by_gaps =
            timed && gap_before(start) && (end == bytes_.size() || gap_before(end));

        if (n >= kMinAdu) {
            const CrcCheck crc = check_crc(piece);
            const Reading shape =
                reading_by_shape(piece, byte_end(start), false, channels_[piece_of(start).channel]);
            if (crc.status != CrcStatus::bad) {
                // CRC right but the length disagrees with the function code.
                const Note malformed{note_id::malformed, "length does not fit its function code"};
                emit(start, n, RecordClass::frame, shape, Delimiter::gap, crc, &malformed);
                start = end;
                continue;
            }
            // What a stop cut off may fit a shorter frame's shape by chance (the first 5
            // bytes of a read, `01 03 00 03 00`, as an answer with no data): it is cut. So
            // is what the end of the input cut, where a likelier reading runs past it.
            if (shape != Reading::unknown && !(stopped_ && end == bytes_.size()) &&
                !fit.cut_by_end) {
                emit(start, n, RecordClass::invalid, shape,
                     bounded_by_gaps ? Delimiter::gap : Delimiter::length_crc, crc);
                start = end;
                continue;
            }
        }
        // The end of a packet the capture cut: what is there of a frame, whatever its shape.
        if (not_captured_ != 0 && end == bytes_.size()) {
            emit_cut_by_capture(start, n);
            start = end;
            continue;
        }
        // What was on the line when a run stopped is cut by the stop, whatever its gaps.
        const bool cut_by_stop = stopped_ && end == bytes_.size();
        if (n >= 3 && (bounded_by_gaps || cut_by_stop) && emit_if_truncated(start, n)) {
            start = end;
            continue;
        }
        if (cut_by_stop) {
            const Note cut{note_id::cut_by_stop,
                           fmt::format("{} {} on the line when the run stopped", n,
                                       n == 1 ? "byte" : "bytes")};
            emit(start, n, RecordClass::noise, Reading::unknown, Delimiter::end_of_input, {}, &cut);
        } else {
            emit(start, n, RecordClass::noise, Reading::unknown, Delimiter::gap, {});
        }
        start = end;
    }
}

bool Framer::proven_gap_before(std::size_t at) const {
    if (at >= bytes_.size()) return false;
    const Piece& piece = piece_of(at);
    if (piece.first != base_ + at) return false;
    if (piece.starts_frame || piece.gap == kBoundary) return true;
    return is_measured(piece.gap) && piece.gap >= t35_ + options_.batching.hold;
}

Framer::DamagedFit Framer::damaged_frame(std::size_t start, std::size_t to,
                                         bool at_boundary_only, int chain, bool at_end) const {
    DamagedFit chosen;
    const std::size_t avail = to - start;
    if (avail < kMinAdu) return chosen;
    const auto head = std::span(bytes_).subspan(start, std::min(avail, kMaxAdu));
    const FrameLengths lengths = options_.rules->frame_lengths(head);
    const bool answer_first = expects_answer_at(start, head);
    // Only a function whose length the table gives (noise often holds another). Of its
    // readings, the likelier, by how its fields bear it out (3: by evidence chance gives
    // once in billions; 2: by evidence that chance rarely gives; 1: by what the reading
    // allows; 0: against it, by one bit error; -1: by more than one):
    //   a request: its word (a quantity, a coil's FF00 or 0000) as allowed 2, one bit
    //     from it 0 (1 for a write where that allowed quantity gives its byte count),
    //     further -1, none to check 1; one answered with data sent to everyone 0;
    //   an answer: an echo or the answer to a write of several that repeats the awaited
    //     request's first six bytes (but for a bit at most) 3; awaited from this slave, or, from it
    //     or an address one bit from it, with the byte count asked, 2; an echo or the answer to a
    //     write of several, of the function awaited from another slave, as its word; another answer
    //     of that function from an address one bit from the asked slave's 1 (the address may be the
    //     byte that took the hit); from any other address, or awaited by none, 0; with an odd count
    //     of registers, at most 0.
    const FunctionSpec& spec = options_.rules->function(head[0], head[1]);
    if (spec.request_length.kind == LengthRule::Kind::search) return chosen;
    const bool reads = spec.access == DataAccess::read && spec.max_quantity != 0;
    const std::uint16_t word = head.size() < 6 ? 0 : word_of(head);
    const auto bytes_for = [&](unsigned items) {
        const bool bits =
            spec.table == DataTable::coils || spec.table == DataTable::discrete_inputs;
        return bits ? (items + 7) / 8 : 2 * items;
    };
    // Whether a word one bit from the request's is allowed; with `giving_count`, one that
    // gives the byte count the request carries (byte 6) as well.
    const auto a_bit_from_allowed = [&](bool giving_count) {
        for (unsigned bit = 0; bit < 16; ++bit) {
            const auto other = static_cast<std::uint16_t>(word ^ (1U << bit));
            if (spec.allows_request_word(other) && (!giving_count || bytes_for(other) == head[6])) {
                return true;
            }
        }
        return false;
    };
    // A device whose valid requests have shown words the function does not allow: a word
    // it does not allow is no evidence against a reading.
    const bool disallowed_seen = disallowed_words_seen_.test(slave_function(head));
    const int word_likely = head.size() < 6 || spec.request_word == RequestWord::none ? 1
                            : spec.allows_request_word(word)                          ? 2
                            : disallowed_seen                                         ? 1
                            : a_bit_from_allowed(false)                               ? 0
                                                                                      : -1;
    // Nobody answers a request sent to everyone: broadcasts are writes (the serial line
    // specification, 2.1), never a function whose answer carries data.
    const bool answered_with_data =
        spec.access != DataAccess::write && spec.answer == Answer::reply;
    // A write of several whose byte count follows its quantity (bytes 6 on).
    const bool counts_its_data = spec.request_length.kind == LengthRule::Kind::counted &&
                                 spec.request_length.n == 6 && head.size() > 6;
    // Its quantity, a bit from one allowed that gives its byte count: the hit was there.
    const int request_likely = head[0] == 0 && answered_with_data ? 0
                               : word_likely == 0 && counts_its_data && a_bit_from_allowed(true)
                                   ? 1
                                   : word_likely;
    const AwaitedAnswer* awaited =
        options_.expectation != nullptr ? options_.expectation->awaited(byte_end(start)) : nullptr;
    const bool exception = (head[1] & 0x80U) != 0;
    // (A read's answer without data is none.)
    const bool counted = spec.response_length.kind == LengthRule::Kind::counted;
    const bool awaited_function = awaited != nullptr && awaited->function == (head[1] & 0x7FU) &&
                                  (exception || head[2] != 0 || !counted);
    // The quantity the awaited request asked for, which gives its answer's byte count.
    unsigned asked = 0;
    if (reads && !exception && awaited_function && counted &&
        awaited->request.size() >= 6) {
        asked = word_of(awaited->request);
        if (asked > spec.max_quantity) asked = 0;
    }
    // Another slave's address one bit from the awaited one's: the address may have taken
    // the hit (further, that takes more than one).
    const bool address_one_bit_off = awaited != nullptr && bits_apart(awaited->slave, head[0]) == 1;
    // As many bytes as asked, or as the asked slave's last valid answer to as many gave,
    // from that slave or an address one bit from it.
    const auto counted_as_before = [&] {
        const auto before = answer_counts_.find(answer_count_key(awaited->slave, head[1], asked));
        return before != answer_counts_.end() && before->second == head[2];
    };
    const bool counted_as_asked = asked != 0 &&
                                  (awaited->slave == head[0] || address_one_bit_off) &&
                                  (head[2] == bytes_for(asked) || counted_as_before());
    const bool answer_awaited = awaited_function && awaited->slave == head[0];
    // An echo, or the answer to a write of several, that repeats the awaited request's
    // first six bytes to the bit, or to all but one (the bit that took the hit): about 1
    // in 2^34 by chance.
    const auto bits_from_request = [&] {
        int bits = 0;
        for (std::size_t i = 0; i < 6; ++i) {
            bits += bits_apart(head[i], awaited->request[i]);
        }
        return bits;
    };
    const bool repeats_request = awaited_function && !exception && spec.answer_repeats_word &&
                                 head.size() >= 6 && awaited->request.size() >= 6 &&
                                 bits_from_request() <= 1;
    // As far as its address and function tell.
    const int answer_likely = repeats_request                      ? 3
                              : answer_awaited || counted_as_asked ? 2
                              : awaited_function && !exception && spec.answer_repeats_word
                                  ? word_likely
                              : awaited_function && address_one_bit_off ? 1
                                                                        : 0;
    // Registers are answered two bytes each: an odd byte count is one bit from an even one
    // (the asked quantity may then give the length), unless the slave has answered so before.
    const bool odd_count_of_registers =
        counted && !exception && !counted_as_asked && head[2] % 2 == 1 &&
        (spec.table == DataTable::holding_registers || spec.table == DataTable::input_registers);
    const int response_likely = odd_count_of_registers ? std::min(answer_likely, 0) : answer_likely;
    // An address, and a function, that valid frames have shown on this bus are likelier
    // than ones they have not (a junk byte read as an address, a data byte as a function).
    const int seen_on_bus = (slaves_seen_.test(head[0]) ? 1 : 0) +
                            (functions_seen_.test(head[1] & 0x7FU) ? 1 : 0);
    // A byte count and a quantity that disagree: one of them took the hit. Both lengths
    // are readings, and where they end decides (a write's own quantity, a read answer's
    // request's); not a write's quantity where this slave's answer to it is awaited (the
    // bytes are likelier that answer than a second write).
    const auto count_a_bit_from_word = [&] {
        return bits_apart(head[6], bytes_for(word)) == 1 || a_bit_from_allowed(true);
    };
    struct Candidate {
        Role role;
        FrameLength length;
        int likely;
    };
    std::array<Candidate, 4> candidates{};
    std::size_t count = 0;
    for (const Role role : {answer_first ? Role::response : Role::request,
                            answer_first ? Role::request : Role::response}) {
        int likely = role == Role::response ? response_likely : request_likely;
        std::optional<std::size_t> from_quantity;
        if (role == Role::request && counts_its_data && request_likely == 2 &&
            head[6] != bytes_for(word)) {
            from_quantity = 9 + bytes_for(word);
        }
        // (Not for an answer whose address already argues against it: that is two hits.)
        if (role == Role::response && answer_likely > 0 && asked != 0 && !counted_as_asked) {
            from_quantity = 5 + bytes_for(asked);
        }
        if (from_quantity) likely = std::min(likely, 1);
        // A byte count more than a bit from the quantity's, and a quantity more than a bit
        // from any allowed one that gives the count, took two hits. So did the asked slave's
        // answer whose count is more than a bit from what a request that came intact asked
        // for (or the slave answers its own way, which no valid answer of it has shown yet).
        if (from_quantity && role == Role::request && !count_a_bit_from_word()) likely = -1;
        if (from_quantity && role == Role::response && answer_awaited &&
            bits_apart(head[2], bytes_for(asked)) > 1 &&
            check_crc(awaited->request).status == CrcStatus::ok) {
            likely = std::min(likely, 0);
        }
        candidates[count++] = {role, lengths.of(role), likely};
        // The quantity's length only where it ends at a boundary and nothing likelier does.
        if (from_quantity && !(role == Role::request && answer_awaited)) {
            candidates[count++] = {role, FrameLength::fixed_at(*from_quantity), 0};
        }
    }
    // The end of the input may be where the recording cut a frame (a run killed, a file
    // still being written): a reading that runs past it, likelier than any that ends
    // before it, says the bytes are that frame's first, not a damaged frame.
    const bool head_ends_input = at_end && to == bytes_.size() && avail <= kMaxAdu;
    std::optional<int> cut_likely;
    for (const Candidate& candidate : std::span(candidates).first(count)) {
        const Role role = candidate.role;
        const FrameLength& length = candidate.length;
        const bool runs_past_end =
            head_ends_input && (length.kind == FrameLength::Kind::need_more ||
                                (length.kind == FrameLength::Kind::fixed && length.bytes > avail));
        if (runs_past_end) {
            cut_likely = std::max(cut_likely.value_or(candidate.likely), candidate.likely);
        }
        if (!length.fixed_within(head.size()) || length.bytes < kMinAdu) continue;
        const std::size_t end = start + length.bytes;
        // Only a silence the batching cannot have made cuts it shorter.
        bool proven = false;
        for (std::size_t gap = gap_after(start, end); gap < end && !proven;
             gap = gap_after(gap, end)) {
            proven = proven_gap_before(gap);
        }
        if (proven) continue;
        // With exact timing, bytes are cut at their silences, and the length decides only
        // where a junk byte or two follow it before the next one (a driver's, switching
        // off): noise between true silences stays noise.
        if (options_.batching.hold == 0 && gap_after(end - 1, to) - end > kMaxJunk) continue;
        // Where it ends: where the next frame or a proven silence begins (3); where
        // another damaged frame that ends so begins (or one or more further damaged frames
        // do, up to `chain`), or a junk byte or two before such a place (2); elsewhere (0).
        const bool at_boundary = end == to || proven_gap_before(end);
        const bool chained = !at_boundary && chain > 0 &&
                             damaged_frame(end, to, true, chain - 1, at_end).length != 0;
        if (at_boundary_only && !at_boundary && !chained) continue;
        bool near_boundary = false;
        for (std::size_t junk = 1; junk <= kMaxJunk && !at_boundary && end + junk <= to; ++junk) {
            near_boundary = near_boundary || end + junk == to || proven_gap_before(end + junk);
        }
        const int where = at_boundary ? 3 : chained || near_boundary ? 2 : 0;
        const int rank = where + candidate.likely + seen_on_bus;
        // One that ends nowhere in particular and that its own fields argue against is none.
        if (rank < 0) continue;
        if (rank > chosen.rank) {
            chosen = {length.bytes, reading_for(role, head[1]), rank, where, candidate.likely};
        }
    }
    if (cut_likely && *cut_likely > chosen.likely) return {.cut_by_end = true};
    return chosen;
}

std::optional<bool> Framer::found_by_chance(const Attempt& there, std::size_t at,
                                            bool at_end) const {
    // A CRC matches one candidate in 65,536, and through bytes that start no frame every
    // byte tries some: a frame found there must also sit where a frame can. Where the
    // input's batching is known, one that reaches over a proven silence without starting
    // at one is a chance match (a frame the line paused in starts after a silence).
    // Batching not understood can show a silence a few bytes from where it was.
    const bool silences_placed = options_.batching.kind != Batching::Kind::unknown;
    const std::size_t end = at + there.length;
    if (silences_placed && !proven_gap_before(at)) {
        for (std::size_t gap = gap_after(at, end); gap < end; gap = gap_after(gap, end)) {
            if (proven_gap_before(gap)) return true;
        }
    }
    bool pending = false;  // bytes still to come decide
    // So is one that neither the next frame nor a silence follows, but another frame
    // starts inside it that they follow: the true frame, whose first bytes the chance
    // match took.
    const Follows after = what_follows(end, at_end);
    if (after == Follows::unknown_yet) pending = true;
    for (std::size_t inner = at + 1; inner < end && after != Follows::boundary; ++inner) {
        const auto head = std::span(bytes_).subspan(inner, std::min(bytes_.size() - inner, kMaxAdu));
        const FrameLengths lengths = options_.rules->frame_lengths(head);
        for (const Role role : {Role::request, Role::response}) {
            const FrameLength& inside = lengths.of(role);
            if (inside.kind != FrameLength::Kind::fixed || inside.bytes < kMinAdu) continue;
            if (inside.bytes > head.size()) {
                pending = pending || (!at_end && inside.bytes <= kMaxAdu);
                continue;
            }
            if (check_crc(head.first(inside.bytes)).status != CrcStatus::ok) continue;
            const Follows follows = what_follows(inner + inside.bytes, at_end);
            if (follows == Follows::boundary) return true;
            pending = pending || follows == Follows::unknown_yet;
        }
    }
    // And one found by its CRC alone (a function without a known length, or the CRC's
    // bytes swapped), or an exception to a function code no table knows (5 bytes whose
    // shape one position in two has), inside the reading of a damaged frame from pos_
    // that ends where the next frame or a silence begins, or where another damaged frame
    // that ends so begins.
    const std::uint8_t function = bytes_[at + 1];
    const bool unknown_exception =
        (function & 0x80U) != 0 &&
        options_.rules->function(bytes_[at], function).request_length.kind == LengthRule::Kind::search;
    const bool weak = there.delimiter == Delimiter::crc_search ||
                      there.crc.status == CrcStatus::swapped || unknown_exception;
    // So is any frame that nothing follows, inside such a reading that its fields make
    // likely (the awaited answer, as long as asked).
    const bool stranded = after == Follows::nothing;
    if ((weak || stranded) && seen_valid_frame_ && !(stopped_ && at_end)) {
        // Whether the next frame or a proven silence begins at `from`; std::nullopt when
        // bytes still to come decide.
        const auto at_frame = [&](std::size_t from) -> std::optional<bool> {
            if (from == bytes_.size()) return at_end ? std::optional(true) : std::nullopt;
            if (proven_gap_before(from)) return true;
            const Attempt next = attempt_at(from, at_end);
            if (next.outcome == Outcome::need_more) return std::nullopt;
            return next.outcome == Outcome::frame && next.crc.status == CrcStatus::ok;
        };
        const DamagedFit fit = damaged_frame(pos_, bytes_.size(), false, 0, at_end);
        const bool awaited_answer = fit.reading == Reading::response && fit.likely >= 2;
        const std::size_t damaged = weak || awaited_answer ? fit.length : 0;
        const std::size_t damaged_end = pos_ + damaged;
        if (damaged != 0) {
            const std::optional<bool> next =
                damaged_end >= end ? at_frame(damaged_end) : std::optional(false);
            if (next.value_or(false)) return true;
            // Or, found by its CRC alone, inside that reading and the next damaged frame's,
            // across the two (a frame of known length nothing follows, there, may be the
            // true one that a damaged frame of lost length runs up to).
            const std::size_t second =
                weak ? damaged_frame(damaged_end, bytes_.size(), false, 0, at_end).length : 0;
            const std::optional<bool> after_second = second != 0 && damaged_end + second >= end
                                                         ? at_frame(damaged_end + second)
                                                         : std::optional(false);
            if (after_second.value_or(false)) return true;
            pending = pending || !next || !after_second;
        }
    }
    if (pending) return std::nullopt;
    // Where the bytes from pos_ are a frame whose CRC fails between two proven silences,
    // a frame inside it is a chance match too, but for one that a junk byte or two
    // before and after are all that is left of that reading.
    if (!silences_placed || !seen_valid_frame_ || !proven_gap_before(pos_) ||
        (stopped_ && at_end)) {
        return false;
    }
    if (!at_end) {
        const auto head = std::span(bytes_).subspan(pos_, std::min(bytes_.size() - pos_, kMaxAdu));
        const FrameLengths lengths = options_.rules->frame_lengths(head);
        for (const Role role : {Role::request, Role::response}) {
            const FrameLength& reach = lengths.of(role);
            if (reach.kind == FrameLength::Kind::fixed && pos_ + reach.bytes >= bytes_.size() &&
                pos_ + reach.bytes > at && reach.bytes <= kMaxAdu) {
                return std::nullopt;
            }
        }
    }
    // Only a reading that chance rarely gives: the next frame's start is not known yet.
    // Where every silence shows, any its fields allow: its bytes, between two silences and
    // none inside, are one frame.
    const DamagedFit fit = damaged_frame(pos_, bytes_.size(), false, kMaxChain, at_end);
    const int least_likely = options_.batching.hold == 0 ? 1 : 2;
    const std::size_t damaged = fit.likely >= least_likely ? fit.length : 0;
    if (damaged == 0 || pos_ + damaged <= at) return false;
    const std::size_t damaged_end = pos_ + damaged;
    if (damaged_end == bytes_.size()) {
        if (!at_end) return std::nullopt;
    } else if (!proven_gap_before(damaged_end)) {
        return false;
    }
    return at - pos_ > kMaxJunk || end + kMaxJunk < damaged_end;
}

std::size_t Framer::end_of_unframed_lines(std::size_t start, std::size_t end) const {
    const Piece& first = piece_of(start);
    const std::size_t line_end = static_cast<std::size_t>(first.end - base_);
    if (line_end >= end) return end;
    // The CRC of the bytes before each candidate's last two, carried from one to the next.
    std::uint16_t crc = 0xFFFF;
    std::size_t crc_to = start;
    std::size_t candidate = line_end;
    for (auto i = static_cast<std::size_t>(&first - pieces_.data());;) {
        const std::size_t n = candidate - start;
        if (n > kMaxAdu) break;
        if (n >= kMinAdu) {
            crc =
                crc16_modbus_update(crc, std::span(bytes_).subspan(crc_to, candidate - 2 - crc_to));
            crc_to = candidate - 2;
            const auto bytes = std::span(bytes_).subspan(start, n);
            if (crc_check_of(bytes, crc).status != CrcStatus::bad ||
                reading_by_shape(bytes, byte_end(start), false, channels_[first.channel]) != Reading::unknown) {
                return candidate;
            }
        }
        if (candidate == end || ++i == pieces_.size()) break;
        candidate = std::min(static_cast<std::size_t>(pieces_[i].end - base_), end);
    }
    return line_end;
}

bool Framer::emit_if_truncated(std::size_t at, std::size_t n) {
    // A broken-off transmission: too short for the length its header implies.
    if (n < 2) return false;
    const auto piece = std::span(bytes_).subspan(at, n);
    const bool answer_first = expects_answer_at(at, piece);
    const FrameLengths lengths = options_.rules->frame_lengths(piece);
    for (const Role role : {answer_first ? Role::response : Role::request,
                            answer_first ? Role::request : Role::response}) {
        const FrameLength& length = lengths.of(role);
        if (length.kind == FrameLength::Kind::fixed && length.bytes > n) {
            const Note truncated =
                stopped_ && at + n == bytes_.size()
                    ? Note{note_id::cut_by_stop,
                           fmt::format("cut by the stop: {} of {} bytes had come", n, length.bytes)}
                    : Note{note_id::truncated,
                           fmt::format("cut short: {} of {} bytes", n, length.bytes)};
            emit(at, n, RecordClass::invalid, reading_for(role, piece[1]), Delimiter::gap, {},
                 &truncated);
            return true;
        }
    }
    return false;
}

void Framer::emit_cut_by_capture(std::size_t at, std::size_t n) {
    const auto piece = std::span(bytes_).subspan(at, n);
    Reading reading = Reading::unknown;
    if (n >= 2) {
        reading = expects_answer_at(at, piece) ? reading_for(Role::response, piece[1])
                                               : Reading::request;
    }
    const Note cut{note_id::cut_by_snaplen,
                   fmt::format("packet cut by the capture's snap length ({} {} not captured)",
                               not_captured_, not_captured_ == 1 ? "byte" : "bytes")};
    emit(at, n, RecordClass::invalid, reading, Delimiter::end_of_input, {}, &cut);
}

void Framer::emit_chunk_as_frame(const Chunk& chunk) {
    Frame& frame = frame_;
    frame.notes.clear();
    frame.start = kNoTime;
    frame.silence_before = kNoTime;
    frame.bytes = chunk.bytes;
    const Nanos duration = has_time(chunk.duration)
                               ? chunk.duration
                               : static_cast<Nanos>(chunk.bytes.size()) * char_time_;
    frame.end = chunk.time;
    if (has_time(chunk.time)) {
        if (options_.chunk_time_is_start) {
            frame.start = chunk.time;
            frame.end = chunk.time + duration;
        } else {
            frame.start = chunk.time - duration;
        }
    }
    if (has_time(frame.start) && has_time(last_end_) && frame.start >= last_end_ &&
        !chunk.time_estimated && !last_end_estimated()) {
        frame.silence_before = frame.start - last_end_;
    }
    packet_first_ = kNoIndex;
    if (has_time(frame.end)) {
        last_end_ = frame.end;
        last_stamp_ = chunk.time;
    }
    seen_bytes_ = true;
    previous_chunk_single_ = false;
    after_whole_frame_ = true;
    frame.channel = chunk.channel;
    frame.source_line = chunk.source_line;
    frame.comments = chunk.comments;
    frame.delimiter = Delimiter::line;
    frame.crc = check_crc(frame.bytes);
    const Reading shape = reading_by_shape(frame.bytes, chunk.time, true, chunk.channel);
    frame.reading = shape;
    // The port a packet came on says which way it went, whatever its shape (a cut-short
    // answer too); without one, the shape and the awaited answer do.
    if (!chunk.channel.empty() && !options_.request_channel.empty() && frame.bytes.size() >= 2) {
        frame.reading = chunk.channel == options_.request_channel
                            ? Reading::request
                            : reading_for(Role::response, frame.bytes[1]);
    }
    frame.cls = frame.crc.status == CrcStatus::bad ? RecordClass::invalid : RecordClass::frame;
    if (frame.bytes.size() < kMinAdu) frame.cls = RecordClass::invalid;
    add_crc_note(frame);
    if (shape == Reading::unknown && frame.cls == RecordClass::frame) {
        frame.notes.add(note_id::malformed, "length does not fit its function code");
    }
    emit_(frame);
}

void Framer::emit_modbus_tcp(const Chunk& chunk) {
    Frame& frame = frame_;
    frame.notes.clear();
    frame.bytes = chunk.bytes;
    frame.transport = Transport::tcp;
    frame.mbap = chunk.mbap;
    // A packet's time, no line time: the turnaround is from packet to packet, as
    // Wireshark's. Nor does it end a silence on any serial line.
    frame.start = chunk.time;
    frame.end = chunk.time;
    frame.silence_before = kNoTime;
    frame.channel = chunk.channel;
    frame.source_line = chunk.source_line;
    frame.comments = chunk.comments;
    frame.delimiter = Delimiter::line;
    frame.crc = {};  // none: TCP checks its segments
    frame.cls = frame.bytes.size() >= 2 ? RecordClass::frame : RecordClass::invalid;
    // The port says which way it went; without one, the pairing decides by transaction id.
    frame.reading = Reading::unknown;
    if (frame.bytes.size() >= 2 && !chunk.channel.empty() && !options_.request_channel.empty()) {
        frame.reading = chunk.channel == options_.request_channel
                            ? Reading::request
                            : reading_for(Role::response, frame.bytes[1]);
    }
    emit_(frame);
    frame.transport = Transport::rtu;
    frame.mbap = {};
}

void Framer::emit(std::size_t at, std::size_t length, RecordClass cls, Reading reading,
                  Delimiter delimiter, CrcCheck crc, const Note* note) {
    Frame& frame = frame_;
    // Emptied and refilled rather than assigned: assign copies in two pieces (over the old
    // bytes, then past them) whenever the frame is longer than the last.
    frame.bytes.clear();
    frame.bytes.insert(frame.bytes.end(), bytes_.begin() + static_cast<std::ptrdiff_t>(at),
                       bytes_.begin() + static_cast<std::ptrdiff_t>(at + length));
    frame.notes.clear();
    frame.cls = cls;
    frame.reading = reading;
    frame.delimiter = delimiter;
    frame.crc = crc;
    // The piece is looked up once: a frame's fields are asked of it several times.
    const Piece& piece = piece_of(at);
    const Nanos first_end = byte_end(piece, at);
    frame.start = has_time(first_end) ? first_end - char_time_ : kNoTime;
    // Most frames lie within one chunk, whose piece is at hand.
    const bool within_piece = base_ + at + length <= piece.end;
    frame.end = within_piece ? byte_end(piece, at + length - 1) : byte_end(at + length - 1);
    const Nanos gap = gap_at(piece, at);
    frame.silence_before = is_measured(gap) ? gap : kNoTime;
    last_record_first_ = base_ + at;
    const std::string& channel = channels_[piece.channel];
    if (frame.channel != channel) frame.channel = channel;
    frame.source_line = piece.line;
    // Noise and frames cut short come without a CRC check, so without a CRC note.
    add_crc_note(frame);
    if (note != nullptr) frame.notes.add(note->id, note->text);
    // Silences are measured only before a chunk's first byte: a frame in the middle of
    // one chunk has none to note.
    if (cls != RecordClass::noise && (piece.first == base_ + at || !within_piece)) {
        add_timing_notes(frame, piece, at, length);
    }
    if (!char_errors_.empty()) add_char_error_note(frame, at, length);
    if (!time_jumps_.empty()) add_time_jump_notes(frame, at, length);
    pos_ = at + length;
    scan_hint_ = 0;
    if (cls == RecordClass::frame) seen_valid_frame_ = true;
    if (crc.status == CrcStatus::ok && frame.bytes.size() >= kMinAdu) {
        slaves_seen_.set(frame.bytes[0]);
        functions_seen_.set(frame.bytes[1] & 0x7FU);
        if (reading == Reading::response) remember_answer_count(frame);
        if (reading == Reading::request) remember_request_word(frame);
    }
    emit_(frame);
}

void Framer::remember_answer_count(const Frame& answer) {
    const AwaitedAnswer* awaited =
        options_.expectation != nullptr ? options_.expectation->awaited(answer.end) : nullptr;
    const auto head = std::span(answer.bytes);
    if (awaited == nullptr || awaited->slave != head[0] || awaited->function != head[1] ||
        awaited->request.size() < 6 ||
        options_.rules->function(head[0], head[1]).response_length.kind !=
            LengthRule::Kind::counted) {
        return;
    }
    const unsigned asked = word_of(awaited->request);
    answer_counts_[answer_count_key(head[0], head[1], asked)] = head[2];
}

void Framer::remember_request_word(const Frame& request) {
    const auto head = std::span(request.bytes);
    const FunctionSpec& spec = options_.rules->function(head[0], head[1]);
    if (head.size() < 8 || spec.request_word == RequestWord::none) return;
    // Bytes that read as well as an answer with a byte count (an answer of 3 bytes of coils
    // is as long as a request) show no word: the transaction may have been that answer.
    if (!spec.answer_repeats_word) {
        const FrameLength as_answer = options_.rules->frame_lengths(head).response;
        if (as_answer.kind == FrameLength::Kind::fixed && as_answer.bytes == head.size()) return;
    }
    if (!spec.allows_request_word(word_of(head))) disallowed_words_seen_.set(slave_function(head));
}

void Framer::add_time_jump_notes(Frame& frame, std::size_t at, std::size_t length) const {
    for (const auto& [index, back] : within_frame(time_jumps_, at, length, &TimeJump::first)) {
        frame.notes.add(note_id::time_backwards,
                        fmt::format("the input's time goes back {:.3f} s here",
                                    static_cast<double>(back) / 1e9));
    }
}

void Framer::add_char_error_note(Frame& frame, std::size_t at, std::size_t length) const {
    std::string hit;
    for (const std::size_t index : within_frame(char_errors_, at, length)) {
        hit += (hit.empty() ? "" : ", ") + std::to_string(index - at + 1);
    }
    if (!hit.empty()) {
        frame.notes.add(note_id::char_error, "parity/framing error on byte " + hit);
    }
}

void Framer::add_timing_notes(Frame& frame, const Piece& first, std::size_t at,
                              std::size_t length) const {
    // Only per-byte timing (one byte per chunk) measures real silences; a chunk of many
    // bytes only says when the adapter handed them over.
    auto measured = [](const Piece& p) { return p.exact && is_measured(p.gap); };
    if (first.first == base_ + at && measured(first) && first.gap < t35_) {
        frame.notes.add(
            note_id::short_gap,
            fmt::format("{:.1f} character times of silence before it (< t3.5)",
                        static_cast<double>(first.gap) / static_cast<double>(char_time_)));
    }
    // Silences inside: before the first byte of every later chunk within the frame.
    Nanos widest = 0;
    for (auto i = static_cast<std::size_t>(&first - pieces_.data()) + 1;
         i < pieces_.size() && pieces_[i].first < base_ + at + length; ++i) {
        if (measured(pieces_[i])) widest = std::max(widest, pieces_[i].gap);
    }
    if (widest > t15_) {
        frame.notes.add(note_id::gap_inside,
                        fmt::format("silence of {:.2f} ms inside (> t1.5)", in_ms(widest)));
    }
}

}  // namespace rtuscope
