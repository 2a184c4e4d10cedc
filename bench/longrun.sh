#!/usr/bin/env bash
# A month of a busy line through `sniff`'s live path, at the speed of the machine: whether
# the sniffer's memory stays flat. FRAMES frames of the benchmarks' traffic
# (bench/traffic.hpp) are played into a pseudo-terminal by rtuscope_bench_pty, as fast as
# the sniffer takes them, and read by
#   rtuscope sniff PTY --baud 115200 --csv --device 1=zb-uvi485 ... \
#       -w DIR/bus.rtucap --rotate-size ROTATE_MB --rotate-files 4 >/dev/null
# every record formatted as a CSV row, decoded with the four seed profiles, counted in
# the closing statistics and recorded into a ring of four files. The sniffer's VmRSS and
# VmHWM (/proc/PID/status) are sampled every second; the summary gives them at 10 %, 50 %
# and 100 % of the run. The run fails (status 1) when the sniffer fails, when it decodes
# other frames than were sent, or when the ring does not hold exactly 4 files at the end.
#   bench/longrun.sh BUILD_DIR [FRAMES [ROTATE_MB]]   (default 50000000 frames, 50 MB)
# LONGRUN_TABLE=FILE keeps every sample (seconds, VmRSS kB, VmHWM kB, MB read).
set -euo pipefail
dir=$1
frames=${2:-50000000}
rotate_mb=${3:-50}
if [[ ! $frames =~ ^[1-9][0-9]{0,9}$ ]]; then
    echo "bench/longrun.sh: FRAMES must be a whole number from 1 to 9999999999, not '$frames'" >&2
    exit 2
fi
work=$(mktemp -d)
feed_pid=""
sniff_pid=""
cleanup() {
    [ -n "$sniff_pid" ] && kill "$sniff_pid" 2>/dev/null
    [ -n "$feed_pid" ] && kill "$feed_pid" 2>/dev/null
    wait 2>/dev/null
    rm -rf "$work"
}
trap cleanup EXIT
fail() {
    echo "bench/longrun.sh: $*" >&2
    exit 1
}

"$dir/bench/rtuscope_bench_pty" --frames "$frames" --baud 115200 --raw "$work/bytes.bin" \
    >"$work/feed" &
feed_pid=$!
for _ in $(seq 100); do [ -s "$work/feed" ] && break; sleep 0.05; done
pty=$(head -1 "$work/feed")
[ -n "$pty" ] || fail "the pseudo-terminal did not open"

mkdir "$work/ring"
devices=(--device "1=zb-uvi485" --device "2=sensor-analyser" --device "3=pdu485" --device "4=zyi-relay")
"$dir/rtuscope" sniff "$pty" --baud 115200 --csv "${devices[@]}" \
    -w "$work/ring/bus.rtucap" --rotate-size "$rotate_mb" --rotate-files 4 \
    >/dev/null 2>"$work/sniff.err" &
sniff_pid=$!

# The clock starts with the first bytes written (the feeder waits for the sniffer).
written() { awk '/^wchar:/ { print $2 }' "/proc/$feed_pid/io" 2>/dev/null || echo 0; }
for _ in $(seq 200); do [ "$(written)" -gt 100 ] && break; sleep 0.05; done
# One sample a second until the feeder has seen every byte read: seconds, VmRSS and
# VmHWM in kB, MB the sniffer has read (the port's bytes, 0xFF doubled by PARMRK, and its
# profiles); and the sniffer's CPU time so far (clock ticks).
table=${LONGRUN_TABLE:-$work/table}
: >"$table"
start=${EPOCHREALTIME/[.,]/}
cpu_ticks=0
sample() {
    local status now read
    status=$(cat "/proc/$sniff_pid/status" 2>/dev/null) || return 0
    now=${EPOCHREALTIME/[.,]/}
    read=$(awk '/^rchar:/ { print $2 }' "/proc/$sniff_pid/io" 2>/dev/null || echo 0)
    awk -v us=$((now - start)) -v mb="$read" '
        /^VmRSS:/ { rss = $2 } /^VmHWM:/ { hwm = $2 }
        END { printf "%.1f %d %d %.1f\n", us / 1e6, rss, hwm, mb / 1e6 }' <<<"$status" >>"$table"
    cpu_ticks=$(awk '{ print $14 + $15 }' "/proc/$sniff_pid/stat" 2>/dev/null || echo "$cpu_ticks")
}
while [ "$(wc -l <"$work/feed")" -lt 2 ]; do
    kill -0 "$sniff_pid" 2>/dev/null || break
    kill -0 "$feed_pid" 2>/dev/null || break
    sample
    sleep 1
done
sample
# The last frames end at the stop, as on a real line when the sniffer is stopped.
kill -INT "$sniff_pid" 2>/dev/null || true
status=0
wait "$sniff_pid" || status=$?
sniff_pid=""
kill "$feed_pid" 2>/dev/null || true
wait "$feed_pid" 2>/dev/null || true
feed_pid=""

[ "$status" -eq 0 ] || fail "sniff ended with status $status: $(cat "$work/sniff.err")"
sent=$(sed -n 2p "$work/feed")
[ -n "$sent" ] || fail "the feeder did not finish: $(cat "$work/sniff.err")"
totals=$(grep -E '^rtuscope: [0-9]+ frames' "$work/sniff.err" | tail -1 | sed 's/^rtuscope: //')
[ -n "$totals" ] || fail "no totals from sniff: $(cat "$work/sniff.err")"
live_bus=$(grep -m1 '^bus: ' "$work/sniff.err" || true)
# The same bytes as a raw dump, with no timing: framed by length and CRC alone.
dump_bus=$("$dir/rtuscope" stats "$work/bytes.bin" --input-format raw --baud 115200 \
    "${devices[@]}" | grep -m1 '^bus: ' || true)
files=$(find "$work/ring" -name 'bus-*.rtucap' | wc -l)
recorded=$(grep -oE 'recorded [0-9]+ files' "$work/sniff.err" | grep -oE '[0-9]+' || echo 1)

echo "sniff's live path: $frames frames of bench/traffic.hpp into a pseudo-terminal as fast as sniff reads them;"
echo "  sniff --baud 115200 --csv >/dev/null, 4 seed profiles, -w --rotate-size $rotate_mb --rotate-files 4"
echo "feeder:   $sent"
echo "sniff:    $totals"
echo "          $live_bus"
echo "raw dump: $dump_bus (rtuscope stats of the same bytes)"
echo "ring:     $recorded files recorded, $files kept"
awk -v frames="$frames" -v sent="$sent" -v ticks="$cpu_ticks" -v hz="$(getconf CLK_TCK)" '
    { t[NR] = $1; rss[NR] = $2; hwm[NR] = $3; mb[NR] = $4
      if ($2 > max_rss) max_rss = $2
      if ($3 > max_hwm) max_hwm = $3 }
    function at(p,   i) { i = int(NR * p + 0.5); if (i < 1) i = 1; return i }
    function row(label, i) {
        printf "  %-5s %7.1f s  VmRSS %6.1f MiB  VmHWM %6.1f MiB  (%.0f MB read)\n",
            label, t[i], rss[i] / 1024, hwm[i] / 1024, mb[i] }
    END {
        if (NR == 0) { print "no samples"; exit }
        n = split(sent, w, " ")
        for (i = 1; i <= n; i++) if (w[i] == "in") seconds = w[i + 1]
        if (seconds > 0) printf "elapsed:  %.1f s, %.0f frames/s; sniff CPU %.1f s\n",
            seconds, frames / seconds, ticks / hz
        printf "RSS (%d samples, one a second):\n", NR
        row("10 %", at(0.1)); row("50 %", at(0.5)); row("100 %", NR)
        printf "  max VmRSS %.1f MiB, VmHWM %.1f MiB; VmRSS at 100 %% less at 10 %%: %+d kB\n",
            max_rss / 1024, max_hwm / 1024, rss[NR] - rss[at(0.1)]
        for (last = NR; last > 1 && rss[last - 1] == rss[NR]; last--) {}
        printf "  VmRSS last changed at %.1f s (%.0f %% of the run), flat for the %d samples after\n",
            t[last], t[last] / t[NR] * 100, NR - last }' "$table"

# Decoding at full speed is decoding by length and CRC alone: the live frames and noise
# bytes are the raw dump's, but for the few frames (about one in ten million) that a read
# of the sniffer's own, late by more than t3.5 while the rest of a frame waits in the
# port, cuts where the tty source takes the delay for a silence. And the ring kept its
# four newest files.
count() { grep -oE "[0-9]+ $2" <<<"$1" | head -1 | grep -oE '^[0-9]+' || echo -1; }
for what in frames "noise bytes"; do
    live=$(count "$live_bus" "$what")
    dump=$(count "$dump_bus" "$what")
    off=$((live > dump ? live - dump : dump - live))
    ((live >= 0 && dump >= 0 && off <= 2 + frames / 100000)) ||
        fail "live: '$live_bus'; the same bytes as a raw dump: '$dump_bus'"
done
[ "$files" -eq 4 ] || fail "$files files in the ring, not 4: $(ls "$work/ring")"
