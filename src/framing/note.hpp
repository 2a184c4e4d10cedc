// A diagnostic attached to a record. Every diagnostic has one stable dotted id, used
// the same in every output (text, CSV, JSONL), as Wireshark's expert info does.
#pragma once

#include <algorithm>
#include <string>
#include <string_view>

#include "util/reused_list.hpp"

namespace rtuscope {

struct Note {
    const char* id = "";  // stable dotted id, e.g. "frame.crc_mismatch"; static storage
    std::string text;     // one short human phrase, e.g. "CRC BAD (expected F6 4E, got B6 4E)"

    void clear() {  // keeps the text's buffer
        id = "";
        text.clear();
    }
};

// A record's notes, in the order they were noticed.
class Notes : public ReusedList<Note> {
  public:
    using ReusedList::add;
    Note& add(const char* id, std::string_view text) {
        Note& note = add();
        note.id = id;
        note.text = text;
        return note;
    }
    [[nodiscard]] bool has(std::string_view id) const {
        return std::any_of(begin(), end(), [&](const Note& n) { return id == n.id; });
    }
};

// The ids in use. Adding one is fine; renaming one breaks users' filters.
namespace note_id {
// framer
inline constexpr const char* crc_mismatch = "frame.crc_mismatch";
inline constexpr const char* crc_swapped = "frame.crc_swapped";
inline constexpr const char* truncated = "frame.truncated";
inline constexpr const char* gap_inside = "frame.gap_inside";            // > t1.5 between two bytes
inline constexpr const char* short_gap = "frame.short_gap";              // < t3.5 before the frame
inline constexpr const char* split_by_length = "frame.split_by_length";  // not delimited by a gap
inline constexpr const char* unknown_length = "frame.unknown_length";  // length found by CRC search
inline constexpr const char* noise = "frame.noise";
inline constexpr const char* char_error = "frame.char_error";  // parity/framing error (tty)
inline constexpr const char* reserved_address = "frame.reserved_address";  // slave 248-255
inline constexpr const char* time_backwards = "frame.time_backwards";      // capture clock jumped
// in progress when a run stopped (--seconds, a signal, the end of a live stream): not an error
inline constexpr const char* cut_by_stop = "frame.cut_by_stop";
// a pcap packet's end that the capture's snap length cut off: not an error of the bus
inline constexpr const char* cut_by_snaplen = "frame.cut_by_snaplen";
// transactions
inline constexpr const char* no_answer = "txn.no_answer";
inline constexpr const char* unsolicited = "txn.unsolicited";  // answer with no request
inline constexpr const char* unexpected_exception = "txn.unexpected_exception";
inline constexpr const char* duplicate_answer = "txn.duplicate_answer";  // 2 answers, 1 request
// still waiting for its answer when a run stopped: not counted as unanswered
inline constexpr const char* stopped_before_answer = "txn.stopped_before_answer";
// PDU decoding
inline constexpr const char* byte_count_mismatch = "pdu.byte_count_mismatch";
inline constexpr const char* malformed = "pdu.malformed";
inline constexpr const char* request_mismatch =
    "pdu.request_mismatch";  // answer disagrees with request
inline constexpr const char* illegal_value = "pdu.illegal_value";
inline constexpr const char* unknown_function = "pdu.unknown_function";
// profiles
inline constexpr const char* over_device_limit =
    "profile.over_device_limit";  // more registers asked than the device allows
}  // namespace note_id

}  // namespace rtuscope
