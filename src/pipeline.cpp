#include "rtuscope/pipeline.hpp"

#include <algorithm>

#include "rtuscope/decoder.hpp"
#include "rtuscope/framer.hpp"

namespace rtuscope {
namespace {

bool has_note(const Record& record, const char* id) {
    return std::any_of(record.notes.begin(), record.notes.end(),
                       [&](const Note& n) { return std::string_view(n.id) == id; });
}

void count(Totals& totals, const Record& record) {
    ++totals.records;
    totals.bytes += record.frame.bytes.size();
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
    if (has_note(record, note_id::no_answer)) ++totals.unanswered;
    if (has_note(record, note_id::unsolicited)) ++totals.unsolicited;
}

}  // namespace

void decode_record(Record& record) {
    const Frame& frame = record.frame;
    if (frame.cls == RecordClass::noise || frame.bytes.size() < 2) return;
    const bool cut_short = frame.bytes.size() < kMinAdu ||
                           std::any_of(record.notes.begin(), record.notes.end(), [](const Note& n) {
                               return std::string_view(n.id) == note_id::truncated;
                           });
    if (cut_short) {
        // No CRC at the end to strip: name the function, decode nothing.
        record.decoded.function_name = function_name(frame.function());
        return;
    }
    const Role role = (record.kind == Kind::response || record.kind == Kind::exception ||
                       frame.reading == Reading::response || frame.reading == Reading::exception)
                          ? Role::response
                          : Role::request;
    std::span<const std::uint8_t> request_pdu;
    if (record.request.size() >= kMinAdu) {
        request_pdu = std::span(record.request).subspan(1, record.request.size() - 3);
    }
    record.decoded = decode_pdu(frame.pdu(), role, request_pdu);
    for (const Note& note : record.decoded.notes) record.notes.push_back(note);
}

Status run_pipeline(ChunkSource& source, const PipelineOptions& options, RecordSink& sink) {
    SessionInfo session;
    session.source = source.info();
    session.line = source.info().line.value_or(LineSettings{});
    if (options.format) {
        const std::uint32_t baud = session.line.baud;
        session.line = *options.format;
        session.line.baud = baud;
    }
    if (options.baud) session.line.baud = *options.baud;
    sink.begin(session);

    Totals totals;
    Transactions transactions({options.timeout, options.rules}, [&](Record&& record) {
        decode_record(record);
        count(totals, record);
        sink.record(record);
    });
    FramerOptions framer_options;
    framer_options.line = session.line;
    framer_options.chunk_is_frame = session.source.chunk_is_frame;
    framer_options.rules = options.rules;
    framer_options.expectation = &transactions;
    Framer framer(framer_options, [&](Frame&& frame) { transactions.push(std::move(frame)); });

    Chunk chunk;
    Status status = ok_status();
    for (;;) {
        Result<bool> more = source.next(chunk);
        if (!more.ok()) {
            status = more.error();
            break;
        }
        if (!*more) break;
        framer.push(chunk);
    }
    framer.finish();
    transactions.finish();
    sink.end(totals, source.remarks());
    return status;
}

}  // namespace rtuscope
