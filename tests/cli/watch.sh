#!/usr/bin/env bash
# `watch` without a terminal: the same tables as text. A replay runs on the capture's own
# clock, so its tables are the same at any speed; a live run records what it heard with
# -w and ends the capture where it stopped; SIGTERM ends it with everything flushed.
# Usage: watch.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
capture=captures/realdata/flowmeter_target_15liter_per_min.rtucap

"$rtuscope" watch "$capture" --speed max --interval 2 >"$work/max" 2>"$work/err" ||
    fail "--speed max: $(cat "$work/err")"
[ "$(grep -c '^-- at ' "$work/max")" -eq 3 ] || fail "not a table every 2 s and one at the end"
"$rtuscope" watch "$capture" --speed 200 --interval 2 >"$work/paced" 2>"$work/err" ||
    fail "--speed 200: $(cat "$work/err")"
diff -u "$work/max" "$work/paced" >&2 || fail "a paced replay differs from --speed max"

# The demo, watched for 3 s with its capture recorded.
"$rtuscope" watch --demo --plain --interval 1 --seconds 3 -w "$work/demo.rtucap" \
    >"$work/demo" 2>"$work/demo.err" || fail "watch --demo: $(cat "$work/demo.err")"
grep -q '^    1 zb-uvi485 ' "$work/demo" || fail "no slave 1 in: $(cat "$work/demo")"
grep -q 'uv_intensity *616.8 µW/cm²' "$work/demo" || fail "no UV intensity in: $(cat "$work/demo")"
grep -q 'voltage *220.5 V' "$work/demo" || fail "no PDU voltage in: $(cat "$work/demo")"
[ "$(tail -1 "$work/demo.rtucap")" = "# stopped (the live run ended here)" ] ||
    fail "the capture does not end with the stop"

# SIGTERM: the tables of the last state, the capture closed, exit status 0 as for the
# end of --seconds (a live run ends by being stopped, as sniff's).
"$rtuscope" watch --demo --plain --interval 60 -w "$work/term.rtucap" >"$work/term" 2>&1 &
pid=$!
sleep 2
kill -TERM $pid
wait $pid
rc=$?
[ $rc -eq 0 ] || fail "SIGTERM: exit status $rc, expected 0"
grep -q '^-- at ' "$work/term" || fail "no last tables after SIGTERM: $(cat "$work/term")"
[ "$(tail -1 "$work/term.rtucap")" = "# stopped (the live run ended here)" ] ||
    fail "the capture is not closed after SIGTERM"
echo "ok"
