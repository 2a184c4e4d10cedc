#!/usr/bin/env bash
# `demo -w FILE` records what the live run knew in the capture's header (the line, the
# device map) and where the run stopped: decoding the file later pairs and names
# everything as the live run did.
# Usage: demo_capture.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$rtuscope" demo --seconds 2 -w "$work/demo.rtucap" >"$work/live" 2>"$work/live.err" ||
    fail "demo: $(cat "$work/live.err")"
grep -q '^# device 1 zb-uvi485$' "$work/demo.rtucap" || fail "no device map in the header"
grep -q '^# written by rtuscope ' "$work/demo.rtucap" || fail "no version in the header"
[ "$(tail -1 "$work/demo.rtucap")" = "# stopped (the live run ended here)" ] ||
    fail "the capture does not end with the stop"
"$rtuscope" decode "$work/demo.rtucap" --no-color >"$work/later" 2>"$work/later.err" ||
    fail "decode: $(cat "$work/later.err")"
grep -q '^devices: zb-uvi485 on 1; sensor-analyser on 2; pdu485 on 3; zyi-relay on 4$' \
    "$work/later" || fail "the decode does not know the devices"
live=$(grep -o '[0-9]* requests\? without answer' "$work/live" | head -1)
later=$(grep -o '[0-9]* requests\? without answer' "$work/later" | head -1)
[ "$live" = "$later" ] || fail "live: $live; decoded later: $later"
grep -q 'Set correction coefficient\|uv_intensity' "$work/later" ||
    fail "the decode does not use the profiles"
echo "ok"
