#!/usr/bin/env bash
# On a terminal the text fits its width: values side by side, no record line wider than
# the terminal; piped, one value per line as before; --no-values hides them. The terminal is
# a pseudo-terminal made by script(1), its width given by COLUMNS (a pseudo-terminal
# made without one has no size of its own).
# Usage: terminal_width.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
command -v script >/dev/null || { echo "FAIL: script(1) (bsdutils) is missing" >&2; exit 1; }
fail() { echo "FAIL: $*" >&2; exit 1; }
args="decode captures/devices/pdu485.hex --device 1=pdu485 --no-color"

on_terminal() {  # COLUMNS ARGS...: rtuscope's stdout on a terminal of that width
    COLUMNS=$1 script -qec "stty cols $1 2>/dev/null; $rtuscope ${*:2}" /dev/null | tr -d '\r'
}

wide=$(on_terminal 90 "$args") || fail "rtuscope on a terminal failed"
piped=$($rtuscope $args) || fail "rtuscope piped failed"
# The records' lines (the closing summary is wrapped by the terminal, never cut).
longest=$(printf '%s\n' "$wide" | grep -v '^-- ' | LC_ALL=C.UTF-8 wc -L)
[ "$longest" -le 90 ] || fail "a record line of $longest columns on a 90-column terminal"
grep -q '…' <<<"$wide" || fail "no line was cut on a 90-column terminal"
grep -qE '^ {28}voltage = 230\.1 V +current = ' <<<"$wide" || fail "values not packed: $wide"
grep -qE '^ {28}voltage {10}= 230\.1 V \(raw 0x08FD\)$' <<<"$piped" || fail "piped: not one value a line"
[ "$(wc -l <<<"$wide")" -lt "$(wc -l <<<"$piped")" ] || fail "packed text is not shorter"
quiet=$(on_terminal 90 "$args --no-values")
grep -qE '^ {28}[a-z_0-9.]+ = ' <<<"$quiet" && fail "--no-values still shows values"
echo ok
