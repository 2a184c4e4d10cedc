#!/usr/bin/env bash
# sniff/demo write each record at once, even into a file; they stop cleanly on SIGTERM
# (output flushed, summary on stderr, exit 0); and a capture written with -w stays valid
# even when the process is killed outright.
# Usage: stop_signals.sh RTUSCOPE
set -euo pipefail
rtuscope=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# SIGTERM: a clean stop.
"$rtuscope" demo --no-color -w "$dir/term.rtucap" >"$dir/term.out" 2>"$dir/term.err" &
pid=$!
sleep 2
# Into a file stdout has a 64 KiB buffer, yet a live run hands over each record at once.
grep -q 'uv_intensity' "$dir/term.out" || fail "nothing in the output file while the demo runs"
kill -TERM "$pid"
rc=0; wait "$pid" || rc=$?
[ "$rc" -eq 0 ] || fail "exit status $rc after SIGTERM: $(cat "$dir/term.err")"
grep -q '^rtuscope: [0-9]* frames' "$dir/term.err" || fail "no summary on stderr after SIGTERM"
grep -q '^-- [0-9]* records' "$dir/term.out" || fail "text output not finished after SIGTERM"
grep -q 'uv_intensity' "$dir/term.out" || fail "nothing decoded before SIGTERM"

# SIGKILL: no chance to clean up, yet the capture decodes up to its last line.
"$rtuscope" demo --no-color -w "$dir/kill.rtucap" >/dev/null 2>&1 &
pid=$!
sleep 2
{ kill -KILL "$pid"; wait "$pid"; } 2>/dev/null || true  # bash reports the killed job on stderr
head -1 "$dir/kill.rtucap" | grep -qx '# rtuscope capture v1' || fail "capture header missing"
"$rtuscope" decode "$dir/kill.rtucap" --no-color >"$dir/kill.out" 2>"$dir/kill.err" ||
  fail "the capture of a killed run does not decode: $(cat "$dir/kill.err")"
grep -q 'uv_intensity\|Read Holding Registers' "$dir/kill.out" || fail "killed capture decodes to nothing"
echo "ok"
