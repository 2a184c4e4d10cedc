// Stage 3, transactions: decides what each frame is (request, answer, exception,
// broadcast), pairs each answer with its request, measures the turnaround, and reports
// requests that got no answer. Records leave in stream order, numbered from 1; a request
// is held back until its fate is known (answered, or not within the timeout). On a serial
// line one request at a time awaits its answer; Modbus/TCP requests await theirs by
// transaction id, several at once.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "decode/decoder.hpp"
#include "framing/expectation.hpp"
#include "framing/frame.hpp"
#include "framing/functions.hpp"
#include "profiles/guess.hpp"
#include "profiles/values.hpp"

namespace rtuscope {

enum class Kind : std::uint8_t {
    request,
    response,
    exception,
    broadcast,
    unknown,  // a valid frame whose role is unclear
    invalid,  // bad CRC or cut short
    noise,
};

std::string_view to_string(Kind kind);

struct Record {
    std::uint64_t number = 0;  // 1-based, stream order
    Frame frame;
    Kind kind = Kind::noise;
    std::uint64_t request_number = 0;   // answers: the request they answer; 0 if none
    Nanos latency = kNoTime;            // answers: end of request to start of answer
    std::uint64_t answer_number = 0;    // requests: the answer that answers them; 0 if none
    // Requests: it waited for an answer (not a broadcast, nor a function never answered),
    // so it has one outcome: an answer, an exception, a broken answer or none.
    bool awaits_answer = false;
    std::vector<std::uint8_t> request;  // answers: the request frame, for decoding
    Notes notes;                        // everything noticed, frame notes first
    DecodedPdu decoded;                 // filled by the decoder stage
    const Profile* profile = nullptr;   // the device's profile, when the bus map has one
    ReusedList<DecodedValue> values;    // its register values in the device's words
    ReusedList<GuessedReading> guesses;  // --guess: readings of the registers no profile covers

    // Empties every field but keeps the buffers: records are reused, one per frame
    // would otherwise cost a dozen allocations.
    void clear();

    // The one rule every count of them follows (the closing summary, stats): a request
    // that waited in vain; an answer to no waiting request (nobody asked, or a second
    // answer to one request).
    [[nodiscard]] bool went_unanswered() const;
    [[nodiscard]] bool answers_no_request() const;
};

// Frames, and their bytes, held back behind an awaited request, at most. A Modbus answer
// follows its request at once, so one this far behind is none; and where nothing else
// bounds the wait (a raw dump has no times, --timeout may be long) a request followed by
// millions of other slaves' answers would hold them all, many times the dump's size; and
// 4,096 frames of a pcap or hex log can be 256 KB each.
inline constexpr std::size_t kMaxFramesAwaiting = 4096;
inline constexpr std::size_t kMaxBytesAwaiting = std::size_t{1} << 20;

struct TransactionOptions {
    Nanos timeout = kNanosPerSecond;  // an answer later than this is no answer
    const ProtocolRules* rules = &standard_rules();
};

class Transactions : public AnswerExpectation {
  public:
    // The record is taken back (and reused) once the call returns; move from it only to
    // keep it.
    using Emit = std::function<void(Record&&)>;

    Transactions(TransactionOptions options, Emit emit);

    // Takes the frame's contents, leaving an earlier record's frame in their place (a
    // swap: the framer's frame and the records' reuse each other's buffers, no copy).
    void push(Frame& frame);
    // Live input: the time is `now` and nothing came; a request whose timeout has passed
    // is given up on now rather than when the next frame arrives.
    void tick(Nanos now);
    // `stopped`: the run was stopped rather than its input ended; a request still waiting
    // is noted txn.stopped_before_answer, not txn.no_answer.
    void finish(bool stopped = false);

    [[nodiscard]] const AwaitedAnswer* awaited(Nanos at) const override;

  private:
    // Called for every request, usually with nothing awaited: `why` becomes a string
    // only when a note is written.
    void give_up_on_request(std::string_view why);
    // A Modbus/TCP frame, already in the slot after the held records.
    void push_modbus_tcp(Record& record);
    // The i-th awaited Modbus/TCP request is given up on.
    void give_up_on_tcp_request(std::size_t i, std::string_view why);
    void release();
    // The i-th held record, oldest first (i <= count_).
    Record& held(std::size_t i) { return slots_[head_ + i]; }
    // The slot after the held records, emptied; it joins them when count_ grows.
    Record& next_slot();

    TransactionOptions options_;
    Emit emit_;
    std::uint64_t next_number_ = 1;
    // Records held back, in slots [head_, head_ + count_): a slot is reused (its buffers
    // too) once its record is emitted, so records are neither allocated nor moved per
    // frame. head_ is back at 0 whenever a frame comes (next_slot).
    std::vector<Record> slots_;
    std::size_t head_ = 0;   // the oldest held record's slot
    std::size_t count_ = 0;  // how many are held; the first is the awaited request, if any
    std::optional<std::size_t> awaiting_;  // index (from the oldest) of the awaited request
    AwaitedAnswer awaited_;
    Nanos awaited_end_ = kNoTime;
    std::size_t bytes_behind_awaited_ = 0;  // of the records held after it
    // The request answered last, until the next request: a second answer to it means
    // two devices share an address.
    struct Answered {
        std::uint8_t slave = 0;
        std::uint8_t function = 0;
        std::uint64_t request_number = 0;
        std::uint64_t answer_number = 0;
    };
    std::optional<Answered> answered_;
    // Modbus/TCP requests awaiting their answers, oldest first.
    struct TcpAwaited {
        std::uint32_t connection = 0;
        std::uint16_t transaction = 0;
        std::size_t index = 0;  // of the held records
        Nanos end = kNoTime;
    };
    std::vector<TcpAwaited> tcp_awaiting_;
    // More requests than this awaiting at once: the oldest is given up on.
    static constexpr std::size_t kMaxTcpAwaiting = 256;
};

}  // namespace rtuscope
