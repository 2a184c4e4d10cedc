// The decoder stage for one record: its PDU by the function entry that applies to its
// slave (the device's own, or the standard's), checks that need the record or the device
// (reserved addresses, the device's register limit), and the register values in the
// device's words when the bus map has its profile (and, asked, guesses for the rest).
#pragma once

#include "framing/functions.hpp"
#include "pairing/transactions.hpp"
#include "profiles/bus.hpp"

namespace rtuscope {

// `rules` are the bus map's when there is one (`bus`), else the standard rules. `guess`:
// the registers no profile covers get their plausible readings (--guess).
void decode_record(Record& record, const ProtocolRules& rules, const Bus* bus,
                   bool guess = false);

}  // namespace rtuscope
