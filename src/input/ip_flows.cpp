// TCP reassembly and what each flow carries. See ip_flows.hpp.
//
// A flow's first payload says what it carries: Modbus RTU when a frame whose CRC checks
// starts it, Modbus/TCP when it is whole MBAP ADUs, else neither; the start of a frame or
// an ADU whose rest has not come yet waits for the next segment. A flow found to carry
// RTU does so for good: a frame with a bad CRC in it is a bad frame, not another protocol.
// A flow found to carry something else becomes RTU only on stronger evidence (a payload
// made of whole frames of lengths their function codes give, CRCs right), since one
// payload in 65,536 of any protocol passes a CRC by chance; it becomes Modbus/TCP on a
// payload of whole ADUs (a capture that began inside one). A flow of Modbus/TCP stays so:
// bytes in it that are no ADU are skipped.
#include "input/ip_flows.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <iterator>

#include "framing/crc.hpp"
#include "framing/functions.hpp"
#include "input/mbap.hpp"

namespace rtuscope {
namespace {

using Bytes = std::span<const std::uint8_t>;

// Farther ahead than this, a segment is not one that came early but a stream whose
// sequence jumped (a capture that missed the connection's new start).
constexpr std::uint64_t kMaxEarlyDistance = std::uint64_t{1} << 20;
// A flow's pending bytes keep no more buffer than this once handed on.
constexpr std::size_t kKeptBufferBytes = std::size_t{4} << 10;

// What starts at the front of a payload, read as Modbus RTU.
struct RtuStep {
    enum class Kind : std::uint8_t {
        frame,       // `length` bytes whose CRC checks, a length the function code allows
        incomplete,  // the start of a frame whose end has not come
        none,        // no frame starts here
    };
    Kind kind = Kind::none;
    std::size_t length = 0;
    bool searched = false;  // a code whose length no field gives: the CRC over all the bytes
};

RtuStep rtu_step(Bytes bytes) {
    RtuStep step;
    if (bytes.size() < 2) {
        step.kind = RtuStep::Kind::incomplete;
        return step;
    }
    const Bytes head = bytes.first(std::min(bytes.size(), kMaxAdu));
    const FrameLengths lengths = standard_rules().frame_lengths(head);
    bool incomplete = false;
    bool search = false;
    int best_rank = 0;  // 2 CRC right, 1 swapped
    for (const Role role : {Role::request, Role::response}) {
        const FrameLength& length = lengths.of(role);
        switch (length.kind) {
            case FrameLength::Kind::fixed: {
                if (length.bytes < kMinAdu) break;
                if (length.bytes > head.size()) {
                    incomplete = incomplete || length.bytes <= kMaxAdu;
                    break;
                }
                const CrcStatus status = check_crc(head.first(length.bytes)).status;
                const int rank = status == CrcStatus::ok ? 2 : status == CrcStatus::swapped ? 1 : 0;
                if (rank > best_rank || (rank == best_rank && rank > 0 && length.bytes < step.length)) {
                    best_rank = rank;
                    step.length = length.bytes;
                }
                break;
            }
            case FrameLength::Kind::need_more:
                incomplete = incomplete || head.size() < kMaxAdu;
                break;
            case FrameLength::Kind::search:
                search = true;
                break;
            case FrameLength::Kind::none:
                break;
        }
    }
    if (best_rank > 0) {
        step.kind = RtuStep::Kind::frame;
        return step;
    }
    step.length = 0;
    // As a hex log's line is: the CRC checking over all of it is enough.
    if (search && bytes.size() >= kMinAdu && bytes.size() <= kMaxAdu &&
        check_crc(bytes).status != CrcStatus::bad) {
        step.kind = RtuStep::Kind::frame;
        step.length = bytes.size();
        step.searched = true;
        return step;
    }
    step.kind = incomplete ? RtuStep::Kind::incomplete : RtuStep::Kind::none;
    return step;
}

// How far the bytes read as Modbus RTU frames, one after another from the first.
struct RtuEvidence {
    std::size_t frames = 0;
    bool whole = false;          // frames and nothing else
    bool incomplete = false;     // ends with the start of a frame
    bool first_searched = false;  // the first frame's length was found by its CRC
};

RtuEvidence rtu_evidence(Bytes bytes) {
    RtuEvidence evidence;
    std::size_t at = 0;
    while (at < bytes.size()) {
        const RtuStep step = rtu_step(bytes.subspan(at));
        if (step.kind == RtuStep::Kind::incomplete) {
            evidence.incomplete = true;
            break;
        }
        if (step.kind == RtuStep::Kind::none) break;
        if (evidence.frames == 0) evidence.first_searched = step.searched;
        ++evidence.frames;
        at += step.length;
    }
    evidence.whole = at == bytes.size();
    return evidence;
}

}  // namespace

FlowKey FlowKey::reversed() const {
    FlowKey key = *this;
    std::swap(key.source, key.destination);
    std::swap(key.source_port, key.destination_port);
    return key;
}

std::size_t FlowKeyHash::operator()(const FlowKey& key) const {
    // FNV-1a over the fields.
    std::uint64_t h = 14695981039346656037ULL;
    auto mix = [&](std::uint8_t byte) { h = (h ^ byte) * 1099511628211ULL; };
    for (const std::uint8_t b : key.source) mix(b);
    for (const std::uint8_t b : key.destination) mix(b);
    mix(static_cast<std::uint8_t>(key.source_port >> 8));
    mix(static_cast<std::uint8_t>(key.source_port));
    mix(static_cast<std::uint8_t>(key.destination_port >> 8));
    mix(static_cast<std::uint8_t>(key.destination_port));
    mix(key.protocol);
    mix(key.ip_version);
    return static_cast<std::size_t>(h);
}

IpFlows::Flow& IpFlows::flow_for(const FlowKey& key, std::string_view channel) {
    if (auto it = flows_.find(key); it != flows_.end()) {
        recent_.splice(recent_.begin(), recent_, it->second.recent);
        return it->second;
    }
    if (flows_.size() >= kMaxFlows) forget_least_recent();
    Flow flow;
    flow.key = key;
    flow.channel = channel;
    const auto is_rtu_port = [this](std::uint16_t port) {
        return std::find(rtu_ports_.begin(), rtu_ports_.end(), port) != rtu_ports_.end();
    };
    if (is_rtu_port(key.destination_port) || is_rtu_port(key.source_port)) {
        flow.protocol = Protocol::rtu;
        flow.channel = is_rtu_port(key.destination_port) ? "master" : "slave";
    } else if (auto reverse = flows_.find(key.reversed()); reverse != flows_.end()) {
        // The answers of a flow whose requests are Modbus are Modbus of the same kind.
        const Protocol protocol = reverse->second.protocol;
        if (protocol == Protocol::rtu || protocol == Protocol::modbus_tcp) flow.protocol = protocol;
    }
    recent_.push_front(key);
    flow.recent = recent_.begin();
    return flows_.emplace(key, std::move(flow)).first->second;
}

void IpFlows::forget_least_recent() {
    const auto it = flows_.find(recent_.back());
    Flow& flow = it->second;
    if (!flow.closed) ++flows_forgotten_;
    flush(flow);
    forget_early(flow);
    recent_.pop_back();
    flows_.erase(it);
}

void IpFlows::tcp(const FlowKey& key, const TcpSegment& segment, Bytes payload, Nanos time,
                  std::string_view channel) {
    Flow& flow = flow_for(key, channel);
    std::uint32_t sequence = segment.sequence;
    if (segment.syn) {
        // A new connection on these ports, unless it is the same SYN again.
        const std::uint32_t start = segment.sequence + 1;
        if (!flow.synced || start != flow.next_sequence) {
            if (flow.synced) flush(flow);
            forget_early(flow);
            flow.synced = true;
            flow.closed = false;
            flow.next_sequence = start;
        }
        sequence = start;
    }
    if (segment.payload_length == 0) {
        if (segment.fin || segment.rst) {
            flush(flow);
            flow.closed = true;
        }
        return;
    }
    if (!flow.synced) {
        // The capture began after the connection did: its bytes start here.
        flow.synced = true;
        flow.next_sequence = sequence;
    }
    Bytes bytes = payload.first(std::min<std::size_t>(payload.size(), segment.payload_length));
    std::uint32_t length = segment.payload_length;
    const auto ahead = static_cast<std::int32_t>(sequence - flow.next_sequence);
    if (ahead < 0) {
        const auto before = static_cast<std::uint32_t>(-static_cast<std::int64_t>(ahead));
        if (before >= length) {
            out_.skipped(Skip::retransmission, key, 1);
            return;
        }
        bytes = bytes.size() > before ? bytes.subspan(before) : Bytes{};
        length -= before;
    } else if (ahead > 0) {
        if (static_cast<std::uint64_t>(ahead) <= kMaxEarlyDistance) {
            add_early(flow, flow.next_offset + static_cast<std::uint64_t>(ahead), bytes, time,
                      length, segment.fin || segment.rst);
            return;
        }
        // Too far ahead to wait for what lies between: the stream starts again here.
        flush(flow);
        ++gaps_skipped_;
        flow.next_sequence = sequence;
    }
    take(flow, bytes, time, static_cast<std::uint32_t>(length - bytes.size()), true);
    flow.next_sequence += length;
    flow.next_offset += length;
    take_early(flow);
    if (segment.fin || segment.rst) {
        flush(flow);
        flow.closed = true;
    }
}

void IpFlows::udp(const FlowKey& key, Bytes payload, std::uint32_t not_captured, Nanos time,
                  std::string_view channel) {
    Flow& flow = flow_for(key, channel);
    take(flow, payload, time, not_captured, false);
}

void IpFlows::add_early(Flow& flow, std::uint64_t offset, Bytes bytes, Nanos time,
                        std::uint32_t length, bool fin) {
    if (auto it = flow.early.find(offset); it != flow.early.end()) {
        if (length <= it->second.length) {
            out_.skipped(Skip::retransmission, flow.key, 1);
            return;
        }
        // A longer segment from the same place: it replaces the shorter one.
        out_.skipped(Skip::retransmission, flow.key, 1);
        flow.early_bytes -= it->second.bytes.size();
        held_bytes_ -= it->second.bytes.size();
        flow.early.erase(it);
    }
    Early early;
    early.bytes.assign(bytes.begin(), bytes.end());
    early.time = time;
    early.length = length;
    early.fin = fin;
    flow.early.emplace(offset, std::move(early));
    flow.early_bytes += bytes.size();
    held_bytes_ += bytes.size();
    if (flow.early_bytes > kMaxHeldBytesPerStream || held_bytes_ > kMaxHeldBytes) {
        ++held_bound_hits_;
        skip_gap(flow);
    }
}

void IpFlows::forget_early(Flow& flow) {
    held_bytes_ -= flow.early_bytes;
    flow.early_bytes = 0;
    flow.early.clear();
}

void IpFlows::take_early(Flow& flow) {
    while (!flow.early.empty()) {
        auto it = flow.early.begin();
        if (it->first > flow.next_offset) break;
        const std::uint64_t before = flow.next_offset - it->first;
        Early early = std::move(it->second);
        flow.early.erase(it);
        flow.early_bytes -= early.bytes.size();
        held_bytes_ -= early.bytes.size();
        if (before >= early.length) {
            out_.skipped(Skip::retransmission, flow.key, 1);
            continue;
        }
        Bytes bytes(early.bytes);
        bytes = bytes.size() > before ? bytes.subspan(before) : Bytes{};
        const auto length = static_cast<std::uint32_t>(early.length - before);
        take(flow, bytes, early.time, static_cast<std::uint32_t>(length - bytes.size()), true);
        flow.next_sequence += length;
        flow.next_offset += length;
        if (early.fin) {
            flush(flow);
            flow.closed = true;
            return;
        }
    }
}

void IpFlows::skip_gap(Flow& flow) {
    while (!flow.early.empty()) {
        hand_on(flow, true, 0);
        const std::uint64_t first = flow.early.begin()->first;
        if (first > flow.next_offset) {
            ++gaps_skipped_;
            bytes_missed_ += first - flow.next_offset;
            flow.next_sequence += static_cast<std::uint32_t>(first - flow.next_offset);
            flow.next_offset = first;
        }
        take_early(flow);
    }
}

void IpFlows::flush(Flow& flow) {
    skip_gap(flow);
    hand_on(flow, true, 0);
}

void IpFlows::take(Flow& flow, Bytes bytes, Nanos time, std::uint32_t not_captured, bool stream) {
    if (bytes.empty()) {
        // The capture kept none of these bytes: what is pending ends where it cut.
        if (not_captured != 0 && !flow.pending.empty()) hand_on(flow, true, not_captured);
        return;
    }
    flow.marks.push_back({flow.pending.size(), time, false});
    flow.pending.insert(flow.pending.end(), bytes.begin(), bytes.end());
    // A datagram stands alone; so does a segment the capture cut.
    hand_on(flow, !stream || not_captured != 0, not_captured);
}

void IpFlows::skip_packets(const Flow& flow, std::size_t from_mark, std::size_t to_mark) {
    if (to_mark <= from_mark) return;
    out_.skipped(Skip::not_modbus, flow.key, to_mark - from_mark);
}

void IpFlows::hand_on(Flow& flow, bool flush, std::uint32_t not_captured) {
    std::vector<std::uint8_t>& pending = flow.pending;
    const std::vector<Mark>& marks = flow.marks;
    const Bytes all(pending);
    // The segment byte `at` came in.
    auto mark_of = [&](std::size_t at) {
        const auto it = std::upper_bound(marks.begin(), marks.end(), at,
                                         [](std::size_t a, const Mark& m) { return a < m.at; });
        return static_cast<std::size_t>(it - marks.begin()) - 1;
    };
    auto next_mark_after = [&](std::size_t at) {
        const std::size_t i = mark_of(at) + 1;
        return i < marks.size() ? marks[i].at : all.size();
    };
    auto send = [&](std::size_t from, std::size_t to) {
        if (to <= from) return;
        const Mark& mark = marks[mark_of(from)];
        out_.rtu(all.subspan(from, to - from), mark.time, mark.estimated || mark.at != from,
                 flow.channel, to == all.size() ? not_captured : 0);
    };

    std::size_t at = 0;
    while (at < all.size()) {
        if (flow.protocol == Protocol::modbus_tcp) {
            // ADUs one after another; one whose rest has not come waits for it.
            const Bytes rest = all.subspan(at);
            const std::size_t adu = mbap_adu_length(rest);
            if (adu != 0 && adu <= rest.size()) {
                const Mark& mark = marks[mark_of(at)];
                out_.modbus_tcp(rest.first(adu), mark.time, mark.estimated || mark.at != at,
                                flow.channel, flow.key);
                at += adu;
                continue;
            }
            const bool header_incomplete = adu == 0 && rest.size() <= kMbapHeaderBytes;
            if (!flush && (adu > rest.size() || header_incomplete)) break;
            // No ADU starts here (or the stream ends inside one): the segment's rest goes.
            const std::size_t next = next_mark_after(at);
            skip_packets(flow, mark_of(at), mark_of(at) + 1);
            at = next;
            continue;
        }
        if (flow.protocol != Protocol::rtu) {
            // `at` begins a segment: what it holds, from here on, says what the flow carries.
            const Bytes rest = all.subspan(at);
            const RtuEvidence rtu = rtu_evidence(rest);
            const bool first = flow.protocol == Protocol::unknown;
            if (first ? rtu.frames > 0 : rtu.whole && !rtu.first_searched) {
                flow.protocol = Protocol::rtu;
                continue;
            }
            if (is_modbus_tcp(rest)) {
                flow.protocol = Protocol::modbus_tcp;
                continue;
            }
            const std::size_t adu = mbap_adu_length(rest);
            if (first && !flush && (rtu.incomplete || adu > rest.size()) &&
                rest.size() < kMaxMbapAdu) {
                break;  // the rest of a frame or ADU may come
            }
            if (first) flow.protocol = Protocol::other;
            const std::size_t next = next_mark_after(at);
            skip_packets(flow, mark_of(at), mark_of(at) + 1);
            at = next;
            continue;
        }
        // Modbus RTU: frames, each chunk the frames that begin in one segment.
        std::size_t chunk = at;
        bool waiting = false;
        while (at < all.size()) {
            if (at > chunk && mark_of(at) != mark_of(chunk)) {
                send(chunk, at);
                chunk = at;
            }
            const RtuStep step = rtu_step(all.subspan(at));
            if (step.kind == RtuStep::Kind::frame) {
                at += step.length;
            } else if (step.kind == RtuStep::Kind::incomplete && !flush) {
                waiting = true;
                break;
            } else if (step.kind == RtuStep::Kind::incomplete) {
                at = all.size();
            } else {
                // No frame starts here: the framer makes what it can of the bytes up to
                // the segment's end.
                at = next_mark_after(at);
            }
        }
        send(chunk, at);
        if (waiting) break;
    }

    // What was handed on goes; the rest keeps its segments' times.
    if (at >= pending.size()) {
        pending.clear();
        flow.marks.clear();
        if (pending.capacity() > kKeptBufferBytes) {
            pending.shrink_to_fit();
        }
        return;
    }
    if (at == 0) return;
    const std::size_t first = mark_of(at);
    std::vector<Mark> kept;
    kept.push_back({0, marks[first].time, marks[first].estimated || marks[first].at != at});
    for (std::size_t i = first + 1; i < marks.size(); ++i) {
        kept.push_back({marks[i].at - at, marks[i].time, marks[i].estimated});
    }
    flow.marks = std::move(kept);
    pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(at));
}

void IpFlows::finish() {
    for (auto it = recent_.rbegin(); it != recent_.rend(); ++it) flush(flows_.at(*it));
}

std::vector<std::string> IpFlows::remarks() const {
    std::vector<std::string> out;
    if (flows_forgotten_ != 0) {
        out.push_back(fmt::format(
            "more than {} TCP and UDP flows at once: {} still active were forgotten, the least "
            "recently active first (what they held was framed as it was)",
            kMaxFlows, flows_forgotten_));
    }
    if (held_bound_hits_ != 0) {
        out.push_back(fmt::format(
            "TCP segments that came early reached the bound of {} KiB a stream or {} MiB in all "
            "{} times: the bytes before them were given up for lost",
            kMaxHeldBytesPerStream >> 10, kMaxHeldBytes >> 20, held_bound_hits_));
    }
    if (gaps_skipped_ != 0) {
        out.push_back(fmt::format(
            "TCP streams miss bytes the capture did not see in {} places{}: the bytes around "
            "them were framed as they were",
            gaps_skipped_,
            bytes_missed_ != 0 ? fmt::format(" ({} bytes)", bytes_missed_) : std::string()));
    }
    return out;
}

}  // namespace rtuscope
