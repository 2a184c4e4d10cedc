#include "pipeline.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "decode/decoder.hpp"
#include "framing/framer.hpp"
#include "output/sinks.hpp"

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

namespace {

// A function code the device defines for itself: its name, and its data explained as
// the profile's layout says.
DecodedPdu decode_own_function(const FunctionOverride& f, std::span<const std::uint8_t> pdu) {
    DecodedPdu d;
    d.function_name = f.name;
    const auto data = pdu.subspan(1);
    if (f.layout == "address_value" && data.size() >= 4) {
        DataBlock block;
        block.custom_table = f.table;
        block.start = static_cast<std::uint16_t>((data[0] << 8) | data[1]);
        block.values.push_back(static_cast<std::uint16_t>((data[2] << 8) | data[3]));
        block.write = true;
        d.summary = fmt::format("0x{:04X} = 0x{:04X}", block.start, block.values[0]);
        if (data.size() != 4) {
            d.notes.push_back({note_id::malformed,
                               fmt::format("{} data bytes, the profile says 4", data.size())});
        }
        d.blocks.push_back(std::move(block));
    } else {
        d.summary = data_bytes_text(data);
        if (f.layout == "address_value") {
            d.notes.push_back({note_id::malformed,
                               fmt::format("{} data bytes, the profile says 4", data.size())});
        }
    }
    return d;
}

// Many devices take fewer registers per request than the standard's 125 (the PDU485:
// 100); a master asking for more gets an exception or silence, and this says why.
void note_over_device_limit(Record& record, const Profile& profile) {
    const auto& b = record.frame.bytes;
    if (b.size() < 8) return;
    const std::uint8_t function = b[1];
    if (function != 0x03 && function != 0x04 && function != 0x10 && function != 0x17) return;
    const auto quantity = static_cast<unsigned>((b[4] << 8) | b[5]);
    if (quantity > profile.max_registers) {
        record.notes.push_back({note_id::over_device_limit,
                                fmt::format("{} registers asked, {} allows at most {}", quantity,
                                            profile.name, profile.max_registers)});
    }
}

// Modbus reserves slave addresses 248-255; a frame there is a garbled address or a device
// that ignores the rule, unless its profile says it uses that address (the PDU485 takes
// up to 250, the ZB-UVI485 broadcasts on 255).
void note_reserved_address(Record& record) {
    const std::uint8_t slave = record.frame.slave();
    if (slave <= 247) return;
    const Profile* p = record.profile;
    if (p != nullptr &&
        (p->broadcast == slave || (slave >= p->first_address && slave <= p->last_address))) {
        return;
    }
    record.notes.push_back(
        {note_id::reserved_address, fmt::format("slave address {} is reserved (248-255)", slave)});
}

}  // namespace

void decode_record(Record& record, const Bus* bus) {
    const Frame& frame = record.frame;
    record.profile = bus != nullptr && !frame.bytes.empty() ? bus->owner(frame.slave()) : nullptr;
    if (frame.cls == RecordClass::noise || frame.bytes.size() < 2) return;
    const bool cut_short = frame.bytes.size() < kMinAdu ||
                           std::any_of(record.notes.begin(), record.notes.end(), [](const Note& n) {
                               return std::string_view(n.id) == note_id::truncated;
                           });
    const FunctionOverride* own =
        record.profile != nullptr
            ? record.profile->function(static_cast<std::uint8_t>(frame.function() & 0x7FU))
            : nullptr;
    if (cut_short) {
        // No CRC at the end to strip: name the function, decode nothing.
        record.decoded.function_name = own != nullptr ? own->name : function_name(frame.function());
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
    if (own != nullptr && !(frame.function() & 0x80U)) {
        record.decoded = decode_own_function(*own, frame.pdu());
    } else {
        decode_pdu(frame.pdu(), role, request_pdu, record.decoded);
        if (own != nullptr) record.decoded.function_name = own->name;
    }
    for (const Note& note : record.decoded.notes) record.notes.push_back(note);
    note_reserved_address(record);
    if (record.profile != nullptr && own == nullptr && role == Role::request) {
        note_over_device_limit(record, *record.profile);
    }
    if (record.profile != nullptr) {
        for (const DataBlock& block : record.decoded.blocks) {
            decode_values(*record.profile, block, record.values);
        }
    }
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
    if (options.bus != nullptr) session.devices = options.bus->map_text();
    sink.begin(session);

    Totals totals;
    std::optional<BusRules> bus_rules;
    if (options.bus != nullptr) bus_rules.emplace(*options.bus);
    const ProtocolRules* rules = bus_rules ? &*bus_rules : &standard_rules();
    Transactions transactions({options.timeout, rules}, [&](Record&& record) {
        decode_record(record, options.bus);
        count(totals, record);
        sink.record(record);
        if (options.live) sink.flush();
    });
    FramerOptions framer_options;
    framer_options.line = session.line;
    framer_options.chunk_is_frame = session.source.chunk_is_frame;
    framer_options.chunk_time_is_start = session.source.chunk_time_is_start;
    framer_options.rules = rules;
    framer_options.expectation = &transactions;
    Framer framer(framer_options, [&](Frame& frame) { transactions.push(frame); });

    Chunk chunk;
    Status status = ok_status();
    for (;;) {
        Result<bool> more = source.next(chunk);
        if (!more.ok()) {
            status = more.error();
            break;
        }
        if (!*more) break;
        // Times beyond kMaxTime would overflow the framer's and the pairing's
        // subtractions (time.hpp; found while fuzzing). Readers may parse them, the
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
            continue;
        }
        framer.push(chunk);
    }
    framer.finish();
    transactions.finish();
    sink.end(totals, source.remarks());
    if (totals_out != nullptr) *totals_out = totals;
    return status;
}

}  // namespace rtuscope
