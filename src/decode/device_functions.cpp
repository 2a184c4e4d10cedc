// A device's own function codes (a profile's [[function]]): their data explained as the
// profile's layout says, requests and answers alike.
#include <fmt/format.h>

#include <array>

#include "decode/pdu_decoders.hpp"
#include "decode/pdu_decoding.hpp"

namespace rtuscope {
namespace {

struct DeviceLayout {
    std::string_view name;
    PduDecoder decoder;
};

// The layouts a profile may name (docs/profiles.md); a function without one is shown as
// bytes (decode_data_bytes).
constexpr std::array<DeviceLayout, 1> kDeviceLayouts = {{
    {"address_value", decode_address_value},
}};

void note_not_four_bytes(PduDecoding& d) {
    d.note(note_id::malformed, fmt::format("{} data bytes, the profile says 4", d.data.size()));
}

}  // namespace

// "address_value": like FC06, a 16-bit address then a 16-bit value, of the profile's table.
//
//   +----+---------+-------+
//   | fc | address | value |
//   +----+---------+-------+
//     1       2        2
void decode_address_value(PduDecoding& d) {
    if (d.data.size() < 4) {
        decode_data_bytes(d);
        note_not_four_bytes(d);
        return;
    }
    DataBlock& block = d.add_block(DataTable::none, *u16_at(d.data, 0), true);
    block.custom_table = d.spec.device_table;
    block.values.assign(1, *u16_at(d.data, 2));
    fmt::format_to(std::back_inserter(d.out.summary), "0x{:04X} = 0x{:04X}", block.start,
                   block.values[0]);
    if (d.data.size() != 4) note_not_four_bytes(d);
}

void decode_data_bytes(PduDecoding& d) {
    append_data_bytes(d.out.summary, d.data);
}

PduDecoder device_layout_decoder(std::string_view name) {
    for (const DeviceLayout& layout : kDeviceLayouts) {
        if (layout.name == name) return layout.decoder;
    }
    return nullptr;
}

std::string_view device_layout_name(PduDecoder decoder) {
    for (const DeviceLayout& layout : kDeviceLayouts) {
        if (layout.decoder == decoder) return layout.name;
    }
    return {};
}

}  // namespace rtuscope
