#!/usr/bin/env bash
# `demo -w FILE --as ...`: a capture's header names profiles, so a slave whose --as
# registers change its profile keeps its profile's name there, and a slave with nothing
# but --as registers is left out; the capture decodes later without them.
# Usage: as_capture.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$rtuscope" demo --seconds 1 -w "$work/demo.rtucap" --as 3:0x0004=u32/cdab --as 9:0=u16 \
    >"$work/live" 2>"$work/live.err" || fail "demo: $(cat "$work/live.err")"
grep -q '^# device 3 pdu485$' "$work/demo.rtucap" || fail "slave 3 lost its profile's name"
grep -q '^# device 9' "$work/demo.rtucap" && fail "slave 9 of --as only is in the header"
"$rtuscope" decode "$work/demo.rtucap" --no-color >"$work/later" 2>"$work/later.err" ||
    fail "decode: $(cat "$work/later.err")"
[ -s "$work/later.err" ] && fail "decode said: $(cat "$work/later.err")"
echo "ok"
