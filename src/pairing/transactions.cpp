#include "pairing/transactions.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace rtuscope {

std::string_view to_string(Kind kind) {
    switch (kind) {
        case Kind::request:
            return "request";
        case Kind::response:
            return "response";
        case Kind::exception:
            return "exception";
        case Kind::broadcast:
            return "broadcast";
        case Kind::unknown:
            return "unknown";
        case Kind::invalid:
            return "invalid";
        case Kind::noise:
            return "noise";
    }
    return "";
}

bool Record::went_unanswered() const {
    return awaits_answer && notes.has(note_id::no_answer);
}

bool Record::answers_no_request() const {
    return notes.has(note_id::unsolicited) || notes.has(note_id::duplicate_answer);
}

void Record::clear() {
    number = 0;
    kind = Kind::noise;
    request_number = 0;
    answer_number = 0;
    awaits_answer = false;
    latency = kNoTime;
    request.clear();
    notes.clear();
    decoded.clear();
    profile = nullptr;
    values.clear();
    guesses.clear();
}

namespace {

// A slot keeps its record's buffers for a later record: records are neither allocated nor
// built anew per frame. Ordinary traffic uses the first few slots (a request, its answer,
// a noise run between them); only a wait (frames held behind an awaited request, up to
// 4,096) reaches further, and those slots give everything back once emitted, or each would
// keep the largest record it ever carried: the values of a 2,000-coil write with a
// profile are ~500 KB. The first slots keep all but the room of a huge frame (a pcap
// packet can be 256 KB, a hex line 512 KB) and of its summary (three characters a byte
// for a function rtuscope does not know).
constexpr std::size_t kSlotsKeepingBuffers = 4;

void give_back_buffers(Record& slot, std::size_t index) {
    if (index >= kSlotsKeepingBuffers) {
        // A swap: a string assigned an empty one (`slot = Record{}`) keeps its room.
        Record emptied;
        std::swap(slot, emptied);
        return;
    }
    constexpr std::size_t kKeptCapacity = 4096;
    if (slot.frame.bytes.capacity() > kKeptCapacity) {
        std::vector<std::uint8_t>().swap(slot.frame.bytes);
    }
    if (slot.request.capacity() > kKeptCapacity) std::vector<std::uint8_t>().swap(slot.request);
    if (slot.decoded.summary.capacity() > kKeptCapacity) std::string().swap(slot.decoded.summary);
}

}  // namespace

Transactions::Transactions(TransactionOptions options, Emit emit)
    : options_(options), emit_(std::move(emit)) {}

const AwaitedAnswer* Transactions::awaited(Nanos at) const {
    if (!awaiting_) return nullptr;
    if (has_time(at) && has_time(awaited_end_) && at - awaited_end_ > options_.timeout) {
        return nullptr;
    }
    return &awaited_;
}

void Transactions::give_up_on_request(std::string_view why) {
    if (!awaiting_) return;
    Record& request = held(*awaiting_);
    std::string text(why);
    if (!options_.rules->answers_errors(request.frame.slave())) {
        text += " (this device answers errors with silence)";
    }
    request.notes.add(note_id::no_answer, std::move(text));
    awaiting_.reset();
    release();
}

// Everything before the oldest awaited request, or everything when none is awaited, is
// final.
void Transactions::release() {
    std::size_t keep_from = awaiting_ ? *awaiting_ : count_;
    for (const TcpAwaited& awaited : tcp_awaiting_) keep_from = std::min(keep_from, awaited.index);
    for (std::size_t i = 0; i < keep_from; ++i) {
        emit_(std::move(slots_[head_]));
        give_back_buffers(slots_[head_], head_);
        ++head_;
        --count_;
    }
    if (awaiting_) *awaiting_ -= keep_from;
    for (TcpAwaited& awaited : tcp_awaiting_) awaited.index -= keep_from;
}

void Transactions::give_up_on_tcp_request(std::size_t i, std::string_view why) {
    held(tcp_awaiting_[i].index).notes.add(note_id::no_answer, std::string(why));
    tcp_awaiting_.erase(tcp_awaiting_.begin() + static_cast<std::ptrdiff_t>(i));
}

// Modbus/TCP: a request awaits the answer with its transaction id on its connection,
// whatever else comes between; its direction (the port) says which is which, else the
// transaction id does.
void Transactions::push_modbus_tcp(Record& record) {
    const Frame& f = record.frame;
    const auto awaited = std::find_if(
        tcp_awaiting_.begin(), tcp_awaiting_.end(), [&](const TcpAwaited& a) {
            return a.connection == f.mbap.connection && a.transaction == f.mbap.transaction;
        });
    const bool is_answer =
        f.cls == RecordClass::frame &&
        (f.reading == Reading::response || f.reading == Reading::exception ||
         (f.reading == Reading::unknown && awaited != tcp_awaiting_.end()));
    if (f.cls != RecordClass::frame) {
        record.kind = Kind::invalid;
    } else if (is_answer) {
        record.kind = (f.function() & 0x80U) != 0 ? Kind::exception : Kind::response;
        if (awaited != tcp_awaiting_.end()) {
            Record& request = held(awaited->index);
            record.request_number = request.number;
            request.answer_number = record.number;
            record.request = request.frame.bytes;
            if (has_time(f.start) && has_time(awaited->end)) record.latency = f.start - awaited->end;
            if (request.frame.slave() != f.slave() ||
                request.frame.function() != (f.function() & 0x7FU)) {
                record.notes.add(note_id::request_mismatch,
                                 fmt::format("request was unit {} function {}",
                                             request.frame.slave(), request.frame.function()));
            }
            tcp_awaiting_.erase(awaited);
        } else {
            record.notes.add(note_id::unsolicited, "answer with no request");
        }
    } else {
        record.kind = Kind::request;
        if (awaited != tcp_awaiting_.end()) {
            give_up_on_tcp_request(static_cast<std::size_t>(awaited - tcp_awaiting_.begin()),
                                   "no answer before its transaction id came again");
        }
        if (tcp_awaiting_.size() >= kMaxTcpAwaiting) {
            give_up_on_tcp_request(
                0, fmt::format("no answer while {} later requests awaited theirs", kMaxTcpAwaiting));
        }
        record.awaits_answer = true;
        tcp_awaiting_.push_back({f.mbap.connection, f.mbap.transaction, count_, f.end});
    }
    ++count_;
    // Held records are bounded, behind a serial request too.
    while (!tcp_awaiting_.empty() && count_ - tcp_awaiting_.front().index > kMaxFramesAwaiting) {
        give_up_on_tcp_request(0, fmt::format("no answer within {} frames", kMaxFramesAwaiting));
    }
    if (awaiting_ && count_ - *awaiting_ > kMaxFramesAwaiting) {
        give_up_on_request(fmt::format("no answer within {} frames", kMaxFramesAwaiting));
    }
    release();
}

Record& Transactions::next_slot() {
    // The held records (none, or an awaited request and what came after it) move back to
    // the first slots, so that ordinary traffic keeps reusing those: after a wait, a run of
    // unanswered requests (each one holding only itself) would otherwise step through every
    // slot the wait had grown. Only an awaited request is ever left behind released
    // records, so this moves one record at most. Swaps keep each record's buffers: the
    // awaited request's bytes stay where `awaited_` sees them.
    if (head_ != 0) {
        for (std::size_t i = 0; i < count_; ++i) std::swap(slots_[i], slots_[head_ + i]);
        head_ = 0;
    }
    if (count_ == slots_.size()) {
        std::vector<Record> bigger(std::max<std::size_t>(16, 2 * slots_.size()));
        for (std::size_t i = 0; i < count_; ++i) bigger[i] = std::move(slots_[i]);
        slots_ = std::move(bigger);
    }
    Record& record = slots_[count_];
    record.clear();
    return record;
}

void Transactions::push(Frame& frame) {
    // Filled in place; held (counted) at the end. Releasing older records on the way
    // leaves the slot where it is: head_ + count_ does not change.
    Record& record = next_slot();
    record.number = next_number_++;
    record.frame.take(frame);
    // The frame's notes open the record's; the record's (empty) list takes their place.
    record.notes.swap(record.frame.notes);
    const Frame& f = record.frame;

    // A request that has waited past the timeout by the time this frame starts.
    tick(f.start);
    if (f.transport == Transport::tcp) {
        push_modbus_tcp(record);
        return;
    }

    const bool matches_awaited =
        awaiting_ && f.slave() == awaited_.slave && (f.function() & 0x7FU) == awaited_.function;
    // A broken frame whose shape says nothing (an answer cut short in a hex log line or a
    // pcap packet) is the answer when it stands where the awaited one would.
    const bool answer_reading =
        f.reading == Reading::response || f.reading == Reading::exception ||
        (f.cls == RecordClass::invalid && f.reading == Reading::unknown && matches_awaited);

    switch (f.cls) {
        case RecordClass::noise:
            record.kind = Kind::noise;
            break;
        case RecordClass::invalid:
            record.kind = Kind::invalid;
            break;
        case RecordClass::frame:
            if (f.reading == Reading::request) {
                record.kind =
                    options_.rules->is_broadcast(f.slave()) ? Kind::broadcast : Kind::request;
            } else if (answer_reading) {
                record.kind = f.reading == Reading::exception ? Kind::exception : Kind::response;
            } else if (matches_awaited) {
                record.kind = (f.function() & 0x80U) ? Kind::exception : Kind::response;
            } else {
                record.kind = Kind::unknown;
            }
            break;
    }

    // A frame seen with a bad CRC may still have reached its slave intact (the damage can
    // be at the tap), so invalid frames take part in pairing by their reading.
    // What the stop cut short is neither: it answers nothing and asks nothing.
    const bool invalid = record.kind == Kind::invalid && !record.notes.has(note_id::cut_by_stop);
    const bool is_answer = record.kind == Kind::response || record.kind == Kind::exception ||
                           (invalid && answer_reading);
    const bool is_request = record.kind == Kind::request || record.kind == Kind::broadcast ||
                            (invalid && f.reading == Reading::request);
    if (is_answer) {
        if (matches_awaited) {
            Record& request = held(*awaiting_);
            record.request_number = request.number;
            request.answer_number = record.number;
            record.request = request.frame.bytes;
            // Inside a chunk the answer's start is a guess: no turnaround then.
            if (has_time(f.silence_before) && has_time(request.frame.end)) {
                record.latency = f.start - request.frame.end;
            }
            awaiting_.reset();
            answered_ = Answered{f.slave(), static_cast<std::uint8_t>(f.function() & 0x7FU),
                                 record.request_number, record.number};
        } else if (answered_ && f.slave() == answered_->slave &&
                   (f.function() & 0x7FU) == answered_->function) {
            record.request_number = answered_->request_number;
            record.notes.add(
                note_id::duplicate_answer,
                fmt::format("second answer to #{} (after #{}): two devices on address {}?",
                            answered_->request_number, answered_->answer_number, f.slave()));
        } else if (!invalid) {
            record.notes.add(note_id::unsolicited, "answer with no request");
        }
    } else if (is_request) {
        answered_.reset();
        // One master, one transaction at a time: a new request ends the wait.
        give_up_on_request("no answer before the next request");
    }

    if (record.kind == Kind::exception && !options_.rules->answers_errors(f.slave())) {
        record.notes.add(note_id::unexpected_exception,
                         "this device is said to answer errors with silence, not exceptions");
    }
    const bool awaits = (record.kind == Kind::request ||
                         (invalid && is_request && !options_.rules->is_broadcast(f.slave()))) &&
                        options_.rules->expects_answer(f.slave(), f.function());
    record.awaits_answer = awaits;
    ++count_;
    if (awaits) {
        awaiting_ = count_ - 1;
        const Frame& request = record.frame;
        awaited_ = {request.slave(), request.function(), request.bytes};
        awaited_end_ = request.end;
        bytes_behind_awaited_ = 0;
    } else if (awaiting_) {
        bytes_behind_awaited_ += f.bytes.size();
        if (count_ - *awaiting_ > kMaxFramesAwaiting) {
            give_up_on_request(fmt::format("no answer within {} frames", kMaxFramesAwaiting));
        } else if (bytes_behind_awaited_ > kMaxBytesAwaiting) {
            give_up_on_request(fmt::format("no answer within {} bytes", kMaxBytesAwaiting));
        }
    }
    release();
}

void Transactions::tick(Nanos now) {
    if (!has_time(now)) return;
    const auto within = [&] {
        return fmt::format("no answer within {:g} s", static_cast<double>(options_.timeout) / 1e9);
    };
    if (awaiting_ && has_time(awaited_end_) && now - awaited_end_ > options_.timeout) {
        give_up_on_request(within());
    }
    bool gave_up = false;
    for (std::size_t i = 0; i < tcp_awaiting_.size();) {
        const Nanos end = tcp_awaiting_[i].end;
        if (has_time(end) && now - end > options_.timeout) {
            give_up_on_tcp_request(i, within());
            gave_up = true;
        } else {
            ++i;
        }
    }
    if (gave_up) release();
}

void Transactions::finish(bool stopped) {
    if (stopped && awaiting_) {
        // Its answer may have been on the way: no fault of the device's.
        held(*awaiting_)
            .notes.add(note_id::stopped_before_answer,
                       "the run stopped before an answer could come");
        awaiting_.reset();
    }
    for (const TcpAwaited& awaited : tcp_awaiting_) {
        held(awaited.index)
            .notes.add(stopped ? note_id::stopped_before_answer : note_id::no_answer,
                       stopped ? "the run stopped before an answer could come"
                               : "no answer before the end of the input");
    }
    tcp_awaiting_.clear();
    give_up_on_request("no answer before the end of the input");
    release();
}

}  // namespace rtuscope
