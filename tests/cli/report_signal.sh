#!/usr/bin/env bash
# --report on a live run: SIGUSR1 writes the page while the run goes on and still starts
# the next -w file (one signal, both), and the end of the run writes the final page.
# Usage: report_signal.sh RTUSCOPE
set -uo pipefail
rtuscope=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
frames_of() { grep -o '"frames":[0-9]*' "$1" | head -1 | cut -d: -f2; }

"$rtuscope" demo --no-color --seconds 5 -w "$dir/bus.rtucap" --rotate-size 100 \
    --report "$dir/bus.html" >/dev/null 2>"$dir/err" &
pid=$!
sleep 2.5
[ -e "$dir/bus.html" ] && fail "a page before the end or a SIGUSR1"
kill -USR1 "$pid"
sleep 1
[ -s "$dir/bus.html" ] || fail "no page within a second of SIGUSR1"
early=$(frames_of "$dir/bus.html")
[ "${early:-0}" -gt 5 ] || fail "the page on SIGUSR1 has ${early:-no} frames"
[ "$(ls "$dir" | grep -c '^bus-.*\.rtucap$')" -eq 2 ] || fail "SIGUSR1 started no second -w file: $(ls "$dir")"
wait "$pid" || fail "demo: $(cat "$dir/err")"
final=$(frames_of "$dir/bus.html")
[ "${final:-0}" -gt "$early" ] || fail "the final page has ${final:-no} frames, the one on SIGUSR1 $early"
grep -q 'id="series-json"' "$dir/bus.html" || fail "the final page has no series"
[ -e "$dir/bus.html.tmp" ] && fail "a temporary page left behind"
# The page is written at the end of a run a signal stops, too.
"$rtuscope" demo --report "$dir/stopped.html" >/dev/null 2>&1 &
pid=$!
sleep 1.5
kill -TERM "$pid"
wait "$pid"
[ -s "$dir/stopped.html" ] || fail "no page after SIGTERM"
# A page that cannot be written is said before the run, in one line.
out=$("$rtuscope" demo --seconds 1 --report "$dir/no/such/dir/bus.html" 2>&1 >/dev/null)
rc=$?
[ "$rc" -eq 1 ] || fail "exit status $rc for a report in a missing directory"
[ "$(wc -l <<<"$out")" -eq 1 ] && grep -q "^rtuscope: error: .*bus.html.*cannot write the report" <<<"$out" ||
    fail "not one line for a report that cannot be written: $out"
echo ok
