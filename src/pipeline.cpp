// The pipeline, source to sink; each stage is a folder of src/:
//
//   input/     a source delivers Chunks: bytes and when they arrived (files, pcap, a tty)
//   framing/   the Framer cuts them into Frames and noise runs, by length, CRC and silence,
//              asking the function table (framing/functions.hpp) how long each frame is
//   pairing/   Transactions decides what each frame is and pairs answers with requests,
//              handing on numbered Records in stream order
//   decode/    decode_record explains each record's PDU, and its register values with a
//              device profile (profiles/)
//   output/    a RecordSink prints them: text, CSV, JSONL, values CSV, pcap (or stats/ counts)
//
// run_pipeline wires them for `decode`, `stats`, `sniff` and `demo`; the command line
// (cli/) picks the source and the sinks.
#include "pipeline.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <deque>

#include "decode/record_decoder.hpp"
#include "framing/batching.hpp"
#include "framing/framer.hpp"
#include "framing/line_check.hpp"
#include "output/sinks.hpp"

namespace rtuscope {

void count_record(Totals& totals, const Record& record) {
    ++totals.records;
    totals.bytes += record.frame.bytes.size();
    if (record.notes.has(note_id::cut_by_stop)) {
        totals.cut_by_stop_bytes += record.frame.bytes.size();
        return;
    }
    // The end of a packet the capture's snap length cut: no fault of the bus's (the
    // source's remarks count such packets).
    if (record.notes.has(note_id::cut_by_snaplen)) return;
    switch (record.kind) {
        case Kind::request:
            ++totals.requests;
            break;
        case Kind::response:
            ++totals.responses;
            break;
        case Kind::exception:
            ++totals.exceptions;
            break;
        case Kind::broadcast:
            ++totals.broadcasts;
            break;
        case Kind::unknown:
            ++totals.unknown;
            break;
        case Kind::invalid:
            ++totals.invalid;
            break;
        case Kind::noise:
            ++totals.noise_runs;
            totals.noise_bytes += record.frame.bytes.size();
            break;
    }
    if (record.frame.crc.status == CrcStatus::bad) ++totals.crc_bad;
    if (record.frame.crc.status == CrcStatus::swapped) ++totals.crc_swapped;
    if (record.went_unanswered()) ++totals.unanswered;
    if (record.answers_no_request()) ++totals.unsolicited;
}

Status run_pipeline(ChunkSource& source, const PipelineOptions& options, RecordSink& sink,
                    Totals* totals_out) {
    SessionInfo session;
    session.source = source.info();
    // The capture header, else the bus file or the devices' profiles, else 9600 8N1.
    std::optional<LineSettings> bus_line;
    if (options.bus != nullptr) bus_line = options.bus->line();
    session.line = source.info().line.value_or(bus_line.value_or(LineSettings{}));
    if (options.format) {
        const std::uint32_t baud = session.line.baud;
        session.line = *options.format;
        session.line.baud = baud;
    }
    if (options.baud) session.line.baud = *options.baud;
    session.baud_origin = options.baud             ? BaudOrigin::option
                          : source.info().line     ? BaudOrigin::input
                          : bus_line               ? BaudOrigin::profiles
                                                   : BaudOrigin::assumed;
    if (options.bus != nullptr) session.devices = options.bus->map_text();

    // How the input batches its bytes, learned from its first chunks: said in the header,
    // and how long a silence must be to prove a frame's end. A file is read ahead that far
    // (a paced replay at most options.read_ahead_time of it); what is learned later, as of
    // a live input, is said at the end.
    const auto stop_requested = [&] { return options.stop != nullptr && options.stop->load(); };
    const bool learns_batching = session.source.timed && !session.source.chunk_time_is_start;
    BatchingLearner learner(session.line);
    std::deque<Chunk> read_ahead;
    std::optional<Status> read_ahead_end;  // what the source said after the chunks read ahead
    if (learns_batching && !options.live && session.source.format != "live") {
        Chunk chunk;
        Nanos first = kNoTime;
        while (!learner.settled() && !stop_requested()) {
            Result<bool> more = source.next(chunk);
            if (!more.ok() || !*more) {
                read_ahead_end = more.ok() ? ok_status() : Status{more.error()};
                break;
            }
            learner.chunk(chunk);
            read_ahead.push_back(chunk);
            // Times out of range stop the run below; they must not overflow this first.
            if (!has_time(chunk.time) || chunk.time > kMaxTime || chunk.time < -kMaxTime) {
                continue;
            }
            if (!has_time(first)) first = chunk.time;
            if (options.read_ahead_time && chunk.time - first > *options.read_ahead_time) break;
        }
        session.batching = learner.verdict().text();
    }
    sink.begin(session);

    Totals totals;
    std::optional<BusRules> bus_rules;
    if (options.bus != nullptr) bus_rules.emplace(*options.bus);
    const ProtocolRules* rules = bus_rules ? &*bus_rules : &standard_rules();
    Transactions transactions({options.timeout, rules}, [&](Record&& record) {
        decode_record(record, *rules, options.bus, options.guess);
        count_record(totals, record);
        sink.record(record);
        if (options.live) sink.flush();
    });
    FramerOptions framer_options;
    framer_options.line = session.line;
    framer_options.chunk_time_is_start = session.source.chunk_time_is_start;
    framer_options.chunk_is_line = session.source.chunk_is_line;
    framer_options.rules = rules;
    framer_options.expectation = &transactions;
    framer_options.batching = learner.verdict();
    // Whether the input looks like RTU at these settings: said at the end, nothing dropped.
    LineCheck line_check(session.line);
    Framer framer(framer_options, [&](Frame& frame) {
        line_check.frame(frame);
        transactions.push(frame);
    });

    bool learned_already = false;  // the chunk at hand was read ahead, and learned from
    const auto next_chunk = [&](Chunk& chunk) -> Result<bool> {
        learned_already = !read_ahead.empty();
        if (!read_ahead.empty()) {
            chunk = std::move(read_ahead.front());
            read_ahead.pop_front();
            return true;
        }
        if (read_ahead_end) {
            if (!read_ahead_end->ok()) return read_ahead_end->error();
            return false;
        }
        return source.next(chunk);
    };
    Chunk chunk;
    Status status = ok_status();
    for (;;) {
        if (stop_requested()) break;
        Result<bool> more = next_chunk(chunk);
        if (!more.ok()) {
            if (!stop_requested()) status = more.error();
            break;
        }
        if (!*more) break;
        // Times beyond kMaxTime would overflow the framer's and the pairing's
        // subtractions (time.hpp). Readers may parse them, the
        // stages cannot use them: stop as at a bad line, keeping what came before.
        if (has_time(chunk.time) && (chunk.time > kMaxTime || chunk.time < -kMaxTime)) {
            status = Error{
                fmt::format("time {:.3f} s out of range (at most {} s either side "
                            "of zero)",
                            static_cast<double>(chunk.time) / 1e9, kMaxTime / kNanosPerSecond),
                source.info().name, chunk.source_line};
            break;
        }
        if (chunk.bytes.empty()) {
            framer.idle(chunk.time, options.idle_margin);
            transactions.tick(chunk.time);
            sink.idle(chunk.time);
            continue;
        }
        line_check.chunk(chunk);
        if (learns_batching && !learned_already && !learner.settled()) {
            learner.chunk(chunk);
            if (learner.settled()) framer.set_batching(learner.verdict());
        }
        framer.push(chunk);
    }
    // A live input does not end: it is stopped, and what was on the line then is cut; so
    // does a capture of a live run.
    const bool stopped = options.live || stop_requested() || source.ended_by_stop();
    framer.finish(stopped);
    transactions.finish(stopped);
    totals.remarks = source.remarks();
    // Learned after the header was printed (a live input's batching).
    if (const std::string said = learner.verdict().text(); !said.empty() && said != session.batching) {
        totals.remarks.push_back("the input came in " + said);
    }
    for (std::string& remark : line_check.remarks()) totals.remarks.push_back(std::move(remark));
    sink.end(totals, totals.remarks);
    if (totals_out != nullptr) *totals_out = totals;
    return status;
}

}  // namespace rtuscope
