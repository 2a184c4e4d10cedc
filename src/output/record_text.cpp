#include "output/record_text.hpp"

#include "util/text.hpp"

namespace rtuscope {

using namespace std::string_view_literals;

void append_pairing(std::string& out, const Record& record, std::string_view before) {
    if (has_time(record.latency)) {
        out += before;
        append_with(out, kMaxMillisChars + kMaxUintChars + 16, [&](char* p) {
            p = write_millis(p, record.latency, 2);
            p = write_text(p, " ms after #");
            return write_uint(p, record.request_number);
        });
    } else if (record.request_number != 0) {
        out += before;
        out += "answers #"sv;
        append_uint(out, record.request_number);
    }
}

void append_note_texts(std::string& out, std::span<const Note> notes) {
    for (std::size_t i = 0; i < notes.size(); ++i) {
        if (i > 0) out += "; "sv;
        out += notes[i].text;
    }
}

void append_value(std::string& out, const DecodedValue& value, std::size_t name_width) {
    append_padded(out, value.name, name_width, false);
    out += " = "sv;
    out += value.value.empty() ? "?"sv : std::string_view(value.value);
    if (!value.unit.empty() && !value.value.empty()) {
        out += ' ';
        out += value.unit;
    }
}

std::size_t append_unlisted_run(std::string& out, std::span<const DecodedValue> values,
                                std::size_t i) {
    std::size_t end = i;
    bool all_zero = true;
    while (end < values.size() && values[end].name.empty()) {
        all_zero = all_zero && values[end].value == "0";
        ++end;
    }
    const std::size_t n = end - i;
    append_hex4(out, values[i].address);
    if (n > 1) {
        out += ".."sv;
        append_hex4(out, values[end - 1].address);
    }
    out += " not in the profile: "sv;
    if (all_zero && n > 1) {
        append_uint(out, n);
        out += " registers, all 0"sv;
    } else {
        for (std::size_t k = i; k < end; ++k) {
            if (k > i) out += ' ';
            out += values[k].raw;
        }
    }
    return end;
}

namespace {

// The end of the readings of guesses[i]'s register.
std::size_t readings_end(std::span<const GuessedReading> guesses, std::size_t i) {
    std::size_t end = i;
    while (end < guesses.size() && guesses[end].address == guesses[i].address) ++end;
    return end;
}

bool all_zero(std::span<const GuessedReading> guesses, std::size_t from, std::size_t to) {
    for (std::size_t k = from; k < to; ++k) {
        if (guesses[k].value != "0"sv && guesses[k].value != "0.0"sv) return false;
    }
    return true;
}

}  // namespace

std::size_t append_guess_line(std::string& out, std::span<const GuessedReading> guesses,
                              std::size_t i) {
    out += "guess "sv;
    append_hex4(out, guesses[i].address);
    // A run of registers whose every reading is 0 (unused ranges devices fill with zeros).
    std::size_t end = readings_end(guesses, i);
    std::size_t registers = 1;
    if (all_zero(guesses, i, end)) {
        for (std::size_t next = end; next < guesses.size(); ++registers) {
            const std::size_t next_end = readings_end(guesses, next);
            if (guesses[next].address != guesses[i].address + registers ||
                !all_zero(guesses, next, next_end)) {
                break;
            }
            end = next_end;
            next = next_end;
        }
    }
    if (registers > 1) {
        out += ".."sv;
        append_hex4(out, guesses[end - 1].address);
        out += ": "sv;
        append_uint(out, registers);
        out += " registers, all 0"sv;
        return end;
    }
    out += " ("sv;
    out += guesses[i].raw;  // the first reading is the u16: the word itself
    out += "):"sv;
    bool pair_begun = false;
    for (std::size_t k = i; k < end; ++k) {
        const GuessedReading& g = guesses[k];
        if (reading_registers(g.reading) == 2 && !pair_begun) {
            pair_begun = true;
            out += " | with "sv;
            append_hex4(out, static_cast<std::uint16_t>(g.address + 1));
            out += ':';
        } else if (k > i) {
            out += ',';
        }
        out += ' ';
        out += reading_name(g.reading);
        out += ' ';
        out += g.value;
    }
    return end;
}

}  // namespace rtuscope
