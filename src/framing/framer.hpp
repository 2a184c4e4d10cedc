// Stage 2, framer: turns chunks into frames and noise runs.
//
// Gaps between characters are the first signal (t3.5 ends a frame), but real lines break
// that rule: USB adapters deliver bytes in 1-16 ms batches, slaves answer sooner than
// t3.5, RS-485 drivers add a junk byte when they switch off. So a frame is found by the
// length its function code implies, confirmed by the CRC; gaps bound the search where no
// field gives the length, and delimit frames whose CRC is wrong. Every input byte ends up
// in exactly one Frame record.
#pragma once

#include <bitset>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "framing/batching.hpp"
#include "framing/crc_end_index.hpp"
#include "framing/expectation.hpp"
#include "framing/frame.hpp"
#include "framing/functions.hpp"
#include "framing/line_settings.hpp"
#include "input/chunk.hpp"

namespace rtuscope {

struct FramerOptions {
    LineSettings line;
    // A chunk's time is its first byte's start (pcap, hex logs), not its last byte's end.
    bool chunk_time_is_start = false;
    // Hex logs: each chunk is a line, so bytes that form no frame are cut at line starts
    // (SourceInfo::chunk_is_line).
    bool chunk_is_line = false;
    const ProtocolRules* rules = &standard_rules();
    const AnswerExpectation* expectation = nullptr;  // usually the pairing stage
    // Two-port taps (one port per direction): chunks tagged with this channel carry the
    // master's requests, chunks of any other channel the slaves' answers. Chunks without
    // a channel are told apart by shape and order as usual.
    std::string request_channel = "master";
    // How the input hands its bytes over (framing/batching.hpp): a silence measured
    // between chunks proves a frame's end only when it exceeds t3.5 by `batching.hold`;
    // while the kind is unknown, silences may show a few bytes from where they were.
    Batching batching;
};

class Framer {
  public:
    // The frame is the framer's, reused once the call returns. A receiver keeps it by
    // copying it or by swapping it with a frame of its own, whose buffers the framer then
    // reuses (it sets every field of the next frame).
    using Emit = std::function<void(Frame&)>;

    Framer(const FramerOptions& options, Emit emit);

    // Adds a chunk; emits every record that the bytes so far decide. A whole-frame chunk
    // (Chunk::whole_frame) is a frame as it is: what is buffered before it is decided as
    // if the input ended there, then it is emitted. A packet (Chunk::packet) is framed on
    // its own the same way: what is buffered before it is decided first, and its start is
    // a frame boundary; a packet the capture cut (Chunk::bytes_not_captured) is decided
    // at once, its unframed end noted as cut by the capture.
    void push(const Chunk& chunk);
    // Live input: nothing has arrived up to `now`. Once the line has been quiet for
    // longer than t3.5 plus `idle_margin`, what is buffered is decided as if the input
    // ended there (the next byte will come after a gap anyway), so a frame whose end no
    // length tells is printed when the line goes idle, not when the next frame starts.
    void idle(Nanos now, Nanos idle_margin);
    // No more input: decides and emits everything still buffered. `stopped`: the input did
    // not end, the run was stopped (a live run, a signal): bytes at the end that form no
    // whole frame were cut by the stop, not broken on the line, and are noted so.
    void finish(bool stopped = false);
    // What was learned of the input's batching since (live input: after the first chunks).
    void set_batching(const Batching& batching) { options_.batching = batching; }

  private:
    enum class Outcome : std::uint8_t { frame, no_frame, need_more };
    struct Attempt {
        Outcome outcome = Outcome::no_frame;
        std::size_t length = 0;
        Reading reading = Reading::unknown;
        Delimiter delimiter = Delimiter::length_crc;
        CrcCheck crc;
        std::size_t wanted = 0;  // need_more: how many bytes from here before trying again
    };

    struct Search {
        std::size_t length = 0;  // 0: none found
        bool pending = false;    // more bytes could still give one
    };
    enum class Follows : std::uint8_t { boundary, nothing, unknown_yet };

    void decide(bool at_end);
    [[nodiscard]] Search search_length(std::size_t at, bool at_end, bool confirm) const;
    // Whether a frame whose length its function code gives, with a right CRC, lies
    // within the `n` bytes after the first at `at`.
    [[nodiscard]] bool holds_known_frame(std::size_t at, std::size_t n) const;
    // Whether a frame ending at `end` is followed by a silence (where `proven`, only one
    // the batching cannot have made), the end or another frame.
    [[nodiscard]] Follows what_follows(std::size_t end, bool at_end, bool proven = false) const;
    Attempt attempt_at(std::size_t at, bool at_end) const;
    // `frame` with what ends it: a silence, the input's end, or its length and CRC alone.
    [[nodiscard]] Attempt with_delimiter(Attempt frame, std::size_t at, bool at_end) const;
    // Whether a frame ending at `end` is followed by a silence (or, at the end of the
    // buffer, by the end of the input).
    [[nodiscard]] bool followed_by_gap(std::size_t end, bool at_end) const;
    // The first byte after `after` with a gap (>= t3.5) before it, looking at most kMaxAdu
    // bytes ahead; past that, any index beyond a whole ADU (a frame's length bound).
    [[nodiscard]] std::size_t next_gap(std::size_t after) const;
    // The first byte in (after, limit) with a gap before it, else `limit`.
    [[nodiscard]] std::size_t gap_after(std::size_t after, std::size_t limit) const;
    [[nodiscard]] bool gap_before(std::size_t at) const;
    // A silence (or the start of the input or of a channel) of at least t3.5.
    [[nodiscard]] bool ends_frame(Nanos gap) const { return gap != kNoTime && gap >= t35_; }
    // `at_end`: as in decide(), no byte follows the ones buffered. `before_frame`: a frame
    // begins at `to`.
    void classify_unframed(std::size_t from, std::size_t to, bool before_frame, bool at_end);
    // A silence at `at` that batching cannot have made up (FramerOptions::batching).
    [[nodiscard]] bool proven_gap_before(std::size_t at) const;
    // A frame whose CRC fails at `start`, before `to` (where the next frame starts): the
    // length its function code (and byte count) gives, with no proven silence inside, and
    // of its readings the likelier; with `at_boundary_only`, only one that ends at `to`, a
    // proven silence or where another such frame starts (with at most `chain` damaged
    // frames in a row before `to` or the silence). With `at_end` and `to` the end of the
    // bytes, nothing follows `to`: a reading may run past the end of the input.
    struct DamagedFit {
        std::size_t length = 0;  // 0: no reading fits
        Reading reading = Reading::unknown;
        int rank = -1;  // where + likely, + 1 each for an address and a function seen
        // Where it ends: 3 at `to` or a proven silence, 2 where damaged frames that end
        // so start or a junk byte or two before such a place, 0 elsewhere.
        int where = 0;
        // How its own fields bear it out, from 3 (evidence chance all but never gives) to
        // -1 (against it by more than one bit error): framer.cpp.
        int likely = 0;
        // No reading fits because a likelier one runs past the end of the input: the
        // bytes are the start of a frame the recording cut (only with `at_end`).
        bool cut_by_end = false;
    };
    [[nodiscard]] DamagedFit damaged_frame(std::size_t start, std::size_t to,
                                           bool at_boundary_only, int chain, bool at_end) const;
    // Whether the frame `there` at `at`, found while looking past bytes from pos_ that
    // start none, is one by chance; std::nullopt when bytes still to come decide.
    [[nodiscard]] std::optional<bool> found_by_chance(const Attempt& there, std::size_t at,
                                                      bool at_end) const;
    // Hex logs: where bytes from `start` that form no frame end, at most at `end`: after
    // the fewest whole lines that have a frame's shape or a right CRC (a frame with a
    // wrong CRC over several lines), else at the end of the line `start` is in.
    [[nodiscard]] std::size_t end_of_unframed_lines(std::size_t start, std::size_t end) const;
    // Which reading the request/answer sequence expects for the bytes `head` at `at`,
    // when both fit: an answer (else a request). On a two-port tap the port they came
    // from says it outright.
    [[nodiscard]] bool expects_answer_at(std::size_t at, std::span<const std::uint8_t> head) const;
    // Whether the pairing stage awaits an answer from this slave and function at `at`.
    [[nodiscard]] bool awaits_answer(std::span<const std::uint8_t> head, Nanos at) const;
    // Request or answer by length alone (or by the awaited answer when both fit). With
    // `any_length_fits_search`, codes whose length no field gives fit any length. Bytes of a
    // two-port tap's `channel` go the way their port says, whenever a reading fits.
    [[nodiscard]] Reading reading_by_shape(std::span<const std::uint8_t> frame, Nanos at,
                                           bool any_length_fits_search,
                                           const std::string& channel) const;
    bool emit_if_truncated(std::size_t at, std::size_t n);
    // The `n` bytes at `at` that end a packet the capture cut, forming no frame.
    void emit_cut_by_capture(std::size_t at, std::size_t n);
    void emit_chunk_as_frame(const Chunk& chunk);
    // A Modbus/TCP ADU (Chunk::transport): a frame without CRC or line timing.
    void emit_modbus_tcp(const Chunk& chunk);
    // `crc`: the check the caller made (none for noise and for frames cut short);
    // `note`: the caller's, if any, after the CRC's.
    void emit(std::size_t at, std::size_t length, RecordClass cls, Reading reading,
              Delimiter delimiter, CrcCheck crc, const Note* note = nullptr);

    // One pushed chunk: what is known of its bytes' timing. Kept per chunk, not per byte:
    // per-byte arrays make the bookkeeping cost more than the framing.
    struct Piece {
        std::uint64_t first = 0;      // stream index of its first byte (base_ + buffer index)
        std::uint64_t end = 0;        // stream index just past its last byte
        Nanos first_start = kNoTime;  // its first byte's estimated start
        // (time - first_start) / bytes and its remainder: see byte_end.
        Nanos step = 0;
        Nanos step_remainder = 0;
        Nanos time = kNoTime;  // its last byte's end (the chunk's time, unless start-stamped)
        Nanos gap = kNoTime;   // silence before its first byte; kBoundary at a start
        int line = 0;
        std::uint32_t channel = 0;  // in channels_
        bool exact = false;         // it and the chunk before came alone (per-byte timing)
        bool starts_frame = false;  // a packet: a frame boundary whatever the silence
    };
    // The chunk byte `at` came in. Asked several times per frame, mostly for the chunk
    // asked last, so that case is inline.
    [[nodiscard]] const Piece& piece_of(std::size_t at) const {
        const std::uint64_t index = base_ + at;
        const std::size_t i = piece_hint_;
        if (i < pieces_.size() && pieces_[i].first <= index && index < pieces_[i].end) {
            return pieces_[i];
        }
        return find_piece(at);
    }
    [[nodiscard]] const Piece& find_piece(std::size_t at) const;
    [[nodiscard]] Nanos byte_end(std::size_t at) const;
    [[nodiscard]] Nanos byte_end(const Piece& piece, std::size_t at) const;  // `at` in `piece`
    // `first`: the piece byte `at` came in.
    void add_timing_notes(Frame& frame, const Piece& first, std::size_t at,
                          std::size_t length) const;
    // Which bytes of the frame at `at` the UART flagged, if any.
    void add_char_error_note(Frame& frame, std::size_t at, std::size_t length) const;
    // Where in the frame at `at` the input's clock went back, if anywhere.
    void add_time_jump_notes(Frame& frame, std::size_t at, std::size_t length) const;
    // What a valid frame shows of its device's ways: an answer's byte count for the
    // quantity asked (answer_counts_), a request's word outside its function's range
    // (disallowed_words_seen_).
    void remember_answer_count(const Frame& answer);
    void remember_request_word(const Frame& request);
    // The silence measured before byte `at`: kNoTime inside a chunk.
    [[nodiscard]] Nanos gap_at(std::size_t at) const;
    [[nodiscard]] Nanos gap_at(const Piece& piece, std::size_t at) const;  // `at` in `piece`
    // The number of a chunk's channel in channels_, a new one if need be.
    std::uint32_t channel_number(const std::string& name);
    // Drops the channel names no buffered chunk has, renumbering the pieces'.
    void forget_unused_channels();
    static constexpr std::size_t kChannelsKept = 16;

    FramerOptions options_;
    Emit emit_;
    Nanos char_time_;
    Nanos t15_;
    Nanos t35_;

    // Bytes not yet emitted, from index `pos_` on; bytes_[0] is byte `base_` of the stream.
    std::vector<std::uint8_t> bytes_;
    std::uint64_t base_ = 0;
    // Where frames could end by their CRC, for the length search (indexed on demand).
    mutable CrcEndIndex crc_ends_;
    std::vector<Piece> pieces_;           // the chunks the buffered bytes came in, in order
    mutable std::size_t piece_hint_ = 0;  // where piece_of last looked: lookups go forward
    // The stream indices of the buffered chunks' first bytes after a silence that ends a
    // frame, in order: searched for the next gap, where walking the chunks costs up to a
    // frame's length of steps at every byte of per-byte captures.
    std::vector<std::uint64_t> frame_gaps_;
    // Bytes the UART flagged (parity/framing), as buffer indices in increasing order. Rare,
    // so sparse.
    std::vector<std::size_t> char_errors_;
    // Where the input's clock went backwards: the index of the first byte of the chunk
    // whose time was earlier than the byte before it, and by how much; in index order.
    // Rare, so sparse.
    using TimeJump = std::pair<std::size_t, Nanos>;
    std::vector<TimeJump> time_jumps_;
    Frame frame_;  // the record being emitted, reused
    std::size_t pos_ = 0;
    // When past pos_: the bytes from pos_ up to it are known to start no frame, which more
    // bytes cannot change. Set only once pos_ has been tried; forgotten when a record goes.
    std::size_t scan_hint_ = 0;
    // The stream index where an attempt waits for more bytes, and how many it waits for.
    std::uint64_t waiting_at_ = ~std::uint64_t{0};
    std::size_t waiting_for_ = 0;
    // Names of the buffered chunks' channels (and of recent ones), forgotten when unused
    // once there are channels_limit_ of them; found by name in channel_numbers_.
    std::vector<std::string> channels_;
    std::unordered_map<std::string, std::uint32_t> channel_numbers_;
    std::size_t channels_limit_ = kChannelsKept;  // forget_unused_channels() when reached
    std::uint32_t last_channel_ = 0;              // the last chunk's
    Nanos last_end_ = kNoTime;                    // the last byte's end, as placed
    Nanos last_stamp_ = kNoTime;                  // the last chunk's time, as the input stamped it
    bool seen_bytes_ = false;
    // A valid frame has been found: bytes before the first may be the tail of a frame the
    // input began in the middle of (a port opened mid-frame), so no length is taken there.
    bool seen_valid_frame_ = false;
    std::bitset<256> slaves_seen_;  // the addresses of frames whose CRC checks
    std::bitset<128> functions_seen_;  // their function codes, without the exception bit
    // The byte count of each slave's last valid answer to a read, by slave, function and
    // the quantity its request asked (answer_count_key): a device may answer its own count
    // whatever is asked (one register, say).
    std::unordered_map<std::uint32_t, std::uint8_t> answer_counts_;
    // By slave and function (slave << 7 | function): a valid request has shown a word
    // (a quantity, a coil's value) the function does not allow (a device that uses the
    // function its own way).
    std::bitset<std::size_t{256} * 128> disallowed_words_seen_;
    bool stopped_ = false;  // finish(true): the bytes at the end were cut by the stop
    // While a packet the capture cut is decided: how many of its bytes it did not keep.
    std::uint32_t not_captured_ = 0;
    bool previous_chunk_single_ = false;
    bool after_whole_frame_ = false;  // the last chunk was a whole frame
    // The stream index of the last record's first byte, and of the last chunk's when it
    // was a packet (else kNoIndex): after a packet of several records, only its first
    // record's start was measured, so its end as placed is a lower bound.
    static constexpr std::uint64_t kNoIndex = ~std::uint64_t{0};
    std::uint64_t last_record_first_ = kNoIndex;
    std::uint64_t packet_first_ = kNoIndex;
    [[nodiscard]] bool last_end_estimated() const {
        return packet_first_ != kNoIndex && last_record_first_ != packet_first_;
    }
};

}  // namespace rtuscope
