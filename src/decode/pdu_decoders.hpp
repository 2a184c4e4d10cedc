// The decoders the function table (framing/functions.cpp) names, one per layout of the
// MODBUS Application Protocol Specification V1.1b3, section 6, grouped as its section 5.1
// groups the function codes; each file has the byte diagrams of its layouts.
#pragma once

#include <cstdint>
#include <string_view>

#include "framing/functions.hpp"

namespace rtuscope {

struct PduDecoding;

// clang-format off
// data_access.cpp: data access
void decode_read_request(PduDecoding& d);              // 6.1-6.4
void decode_read_bits_response(PduDecoding& d);        // 6.1, 6.2
void decode_read_registers_response(PduDecoding& d);   // 6.3, 6.4, 6.17
void decode_write_single_coil(PduDecoding& d);         // 6.5
void decode_write_single_register(PduDecoding& d);     // 6.6
void decode_write_multiple_request(PduDecoding& d);    // 6.11, 6.12
void decode_write_multiple_response(PduDecoding& d);   // 6.11, 6.12
void decode_mask_write_register(PduDecoding& d);       // 6.16
void decode_read_write_request(PduDecoding& d);        // 6.17
void decode_read_fifo_request(PduDecoding& d);         // 6.18
void decode_read_fifo_response(PduDecoding& d);        // 6.18

// file_records.cpp: file record access
void decode_read_file_request(PduDecoding& d);   // 6.14
void decode_read_file_response(PduDecoding& d);  // 6.14
void decode_write_file_record(PduDecoding& d);   // 6.15

// diagnostics.cpp: serial line diagnostics
void decode_bare_request(PduDecoding& d);                     // 6.7, 6.9, 6.10, 6.13
void decode_exception_status_response(PduDecoding& d);        // 6.7
void decode_diagnostics(PduDecoding& d);                      // 6.8
void decode_comm_event_counter_response(PduDecoding& d);      // 6.9
void decode_comm_event_log_response(PduDecoding& d);          // 6.10
void decode_report_server_id_response(PduDecoding& d);        // 6.13

// encapsulated.cpp: 6.19 Encapsulated Interface Transport, 6.20, 6.21
void decode_encapsulated_interface(PduDecoding& d);
// MEI type 0E gives 2B a name of its own, for its exceptions too.
inline constexpr std::uint8_t kMeiDeviceIdentification = 0x0E;
inline constexpr std::string_view kDeviceIdentificationName = "Read Device Identification";

// decoder.cpp: codes without a public layout (section 5, Annex A)
void decode_unknown_function(PduDecoding& d);

// device_functions.cpp: a profile's own function codes, by the layout the profile names
void decode_address_value(PduDecoding& d);  // "address_value": a 16-bit address and value
void decode_data_bytes(PduDecoding& d);     // no layout: the data as bytes
// clang-format on

// The decoder of a layout by its name in a profile ("address_value"), nullptr for a name
// no layout has; and the name of a decoder's layout, "" for none.
PduDecoder device_layout_decoder(std::string_view name);
std::string_view device_layout_name(PduDecoder decoder);

}  // namespace rtuscope
