#!/usr/bin/env bash
# What `watch` costs on a line as busy as 115200 baud allows: its CPU time over the wall
# time and its peak RSS while it shows the dashboard (in a terminal of tmux's) for
# SECONDS, the bus in a process of its own (rtuscope_bench_busy_bus), so that only the
# sniffer is measured. The traffic is CAPTURE played onto the virtual line SPEED times as
# fast as recorded (scripts/bench: rtuscope_bench_gen's at 115200 baud, 8 times: the
# line some 75 % busy), or with CAPTURE "seed" the four seed devices polled with no
# pause; the utilisation printed is what watch's own recording shows.
#   bench/watch.sh BUILD_DIR CAPTURE|seed [SECONDS [SPEED]]   (default 60 s, speed 8)
set -euo pipefail
dir=$1
capture=$2
seconds=${3:-60}
speed=${4:-8}
work=$(mktemp -d)
socket="rtuscope-bench-$$"
bus_pid=""
cleanup() {
    [ -n "$bus_pid" ] && kill "$bus_pid" 2>/dev/null
    tmux -L "$socket" kill-server 2>/dev/null
    rm -rf "$work"
}
trap cleanup EXIT

if [ "$capture" = seed ]; then
    "$dir/bench/rtuscope_bench_busy_bus" --baud 115200 >"$work/port" &
    traffic="the seed devices polled with no pause"
else
    "$dir/bench/rtuscope_bench_busy_bus" --baud 115200 --capture "$capture" --speed "$speed" >"$work/port" &
    traffic="$(basename "$capture") at $speed times its pace"
fi
bus_pid=$!
for _ in $(seq 50); do [ -s "$work/port" ] && break; sleep 0.1; done
port=$(head -1 "$work/port")
[ -n "$port" ] || { echo "bench/watch.sh: the virtual bus did not start" >&2; exit 1; }

# GNU time: CPU and peak RSS of watch alone; the dashboard on a 120x40 terminal.
tmux -L "$socket" -f /dev/null new-session -d -x 120 -y 40 \
    "/usr/bin/time -f '%U %S %e %M' -o '$work/time' '$(realpath "$dir/rtuscope")' watch '$port' --baud 115200 --seconds $seconds -w '$work/bus.rtucap'; touch '$work/done'"
for _ in $(seq $((seconds * 10 + 300))); do [ -e "$work/done" ] && break; sleep 0.1; done
read -r user sys wall rss < "$work/time"
bus=$("$dir/rtuscope" stats "$work/bus.rtucap" --jsonl 2>/dev/null | head -1)
frames=$(grep -o '"frames":[0-9]*' <<< "$bus" | cut -d: -f2)
busy=$(grep -o '"utilisation_pct":[0-9.]*' <<< "$bus" | cut -d: -f2)
awk -v u="$user" -v s="$sys" -v w="$wall" -v r="$rss" -v f="$frames" -v b="$busy" -v t="$traffic" 'BEGIN {
    printf "watch, 115200 baud, %s, %.0f s: %d frames (%.0f/s), line %.0f %% busy; CPU %.1f %% of one core (user %.2f s, sys %.2f s), peak RSS %.1f MiB\n",
        t, w, f, f / w, b, (u + s) / w * 100, u, s, r / 1024 }'
