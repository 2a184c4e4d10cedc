#include "decode/record_decoder.hpp"

#include <fmt/format.h>

#include "decode/decoder.hpp"
#include "profiles/guess.hpp"
#include "profiles/values.hpp"

namespace rtuscope {
namespace {

// Many devices take fewer registers per request than the standard's 125 (the PDU485:
// 100); a master asking for more gets an exception or silence, and this says why. The
// register reads and writes (03, 04, 10, 17) carry their quantity in bytes 3-4 of the PDU.
void note_over_device_limit(Record& record, const FunctionSpec& spec, const Profile& profile) {
    const bool counts_registers =
        spec.max_quantity != 0 &&
        (spec.table == DataTable::holding_registers || spec.table == DataTable::input_registers);
    const auto pdu = record.frame.pdu();
    if (!counts_registers || pdu.size() < 5) return;
    const auto quantity = static_cast<unsigned>((pdu[3] << 8) | pdu[4]);
    if (quantity > profile.max_registers) {
        record.notes.add(note_id::over_device_limit,
                         fmt::format("{} registers asked, {} allows at most {}", quantity,
                                     profile.name, profile.max_registers));
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
    record.notes.add(note_id::reserved_address,
                     fmt::format("slave address {} is reserved (248-255)", slave));
}

}  // namespace

void decode_record(Record& record, const ProtocolRules& rules, const Bus* bus, bool guess) {
    const Frame& frame = record.frame;
    record.profile = bus != nullptr && !frame.bytes.empty() ? bus->owner(frame.slave()) : nullptr;
    if (frame.cls == RecordClass::noise || frame.bytes.size() < 2) return;
    const FunctionSpec& spec = rules.function(frame.slave(), frame.function());
    if (frame.pdu().empty() || record.notes.has(note_id::truncated) ||
        record.notes.has(note_id::cut_by_stop) || record.notes.has(note_id::cut_by_snaplen)) {
        // Cut short (no CRC at the end to strip): name the function, decode nothing.
        record.decoded.function = &spec;
        record.decoded.function_name = spec.name;
        return;
    }
    const Role role = (record.kind == Kind::response || record.kind == Kind::exception ||
                       frame.reading == Reading::response || frame.reading == Reading::exception)
                          ? Role::response
                          : Role::request;
    decode_pdu(spec, frame.pdu(), role, pdu_of(record.request, frame.transport), record.decoded);
    for (const Note& note : record.decoded.notes) record.notes.add(note.id, note.text);
    note_reserved_address(record);
    if (record.profile != nullptr && role == Role::request) {
        note_over_device_limit(record, spec, *record.profile);
    }
    if (record.profile != nullptr) {
        for (const DataBlock& block : record.decoded.blocks) {
            decode_values(*record.profile, block, record.values);
        }
    }
    if (guess) {
        for (const DataBlock& block : record.decoded.blocks) {
            guess_readings(record.profile, block, record.guesses);
        }
    }
}

}  // namespace rtuscope
