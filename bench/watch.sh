#!/usr/bin/env bash
# What `watch` costs on a line as busy as 115200 baud allows: its CPU time over the wall
# time and its peak RSS while it shows the dashboard (in a terminal of tmux's) for
# SECONDS, the bus simulated in a process of its own (rtuscope_bench_busy_bus), so that
# only the sniffer is measured.
#   bench/watch.sh BUILD_DIR [SECONDS]     (default 60; scripts/bench runs it)
set -euo pipefail
dir=$1
seconds=${2:-60}
work=$(mktemp -d)
socket="rtuscope-bench-$$"
bus_pid=""
cleanup() {
    [ -n "$bus_pid" ] && kill "$bus_pid" 2>/dev/null
    tmux -L "$socket" kill-server 2>/dev/null
    rm -rf "$work"
}
trap cleanup EXIT

"$dir/bench/rtuscope_bench_busy_bus" --baud 115200 >"$work/port" &
bus_pid=$!
for _ in $(seq 50); do [ -s "$work/port" ] && break; sleep 0.1; done
port=$(head -1 "$work/port")
[ -n "$port" ] || { echo "bench/watch.sh: the virtual bus did not start" >&2; exit 1; }

# GNU time: CPU and peak RSS of watch alone; the dashboard on a 120x40 terminal.
tmux -L "$socket" -f /dev/null new-session -d -x 120 -y 40 \
    "/usr/bin/time -f '%U %S %e %M' -o '$work/time' '$(realpath "$dir/rtuscope")' watch '$port' --baud 115200 --seconds $seconds -w '$work/bus.rtucap'; touch '$work/done'"
for _ in $(seq $((seconds * 10 + 300))); do [ -e "$work/done" ] && break; sleep 0.1; done
read -r user sys wall rss < "$work/time"
frames=$("$dir/rtuscope" stats "$work/bus.rtucap" --jsonl | head -1 | grep -o '"frames":[0-9]*' | cut -d: -f2)
awk -v u="$user" -v s="$sys" -v w="$wall" -v r="$rss" -v f="$frames" 'BEGIN {
    printf "watch, 115200 baud, %.0f s: %d frames (%.0f/s), CPU %.2f %% of one core (user %.2f s, sys %.2f s), peak RSS %.1f MiB\n",
        w, f, f / w, (u + s) / w * 100, u, s, r / 1024 }'
