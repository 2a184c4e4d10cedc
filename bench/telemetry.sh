#!/usr/bin/env bash
# What publishing costs: `rtuscope sniff PORT --baud 115200 --mqtt ... --metrics ...` for
# SECONDS on the virtual bus of the four seed devices polled with no pause (the bus in a
# process of its own, rtuscope_bench_busy_bus), every value published to a mosquitto
# broker started here on a free localhost port; its CPU time over the wall time and
# peak RSS, with `sniff` alone on the same bus for comparison.
#   bench/telemetry.sh BUILD_DIR [SECONDS]   (default 60)
set -euo pipefail
dir=$1
seconds=${2:-60}
work=$(mktemp -d)
bus_pid=""
broker=""
cleanup() {
    [ -n "$bus_pid" ] && kill "$bus_pid" 2>/dev/null
    [ -n "$broker" ] && kill "$broker" 2>/dev/null
    rm -rf "$work"
}
trap cleanup EXIT
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
printf 'listener %s 127.0.0.1\nallow_anonymous true\npersistence false\n%s\n' "$port" \
    "$( [ "$(id -u)" -eq 0 ] && echo 'user root' )" >"$work/mosquitto.conf"
/usr/sbin/mosquitto -c "$work/mosquitto.conf" >/dev/null 2>&1 &
broker=$!
"$dir/bench/rtuscope_bench_busy_bus" --baud 115200 >"$work/port" &
bus_pid=$!
for _ in $(seq 50); do [ -s "$work/port" ] && break; sleep 0.1; done
tty=$(head -1 "$work/port")
sleep 1
measure() {  # label, then the options
    local label=$1
    shift
    /usr/bin/time -f '%U %S %e %M' -o "$work/time" "$dir/rtuscope" sniff "$tty" --baud 115200 \
        --seconds "$seconds" --csv "$@" >"$work/out" 2>"$work/err"
    read -r user sys wall rss <"$work/time"
    local frames
    frames=$(wc -l <"$work/out")
    awk -v l="$label" -v u="$user" -v s="$sys" -v w="$wall" -v r="$rss" -v f="$frames" 'BEGIN {
        printf "%s, 115200 baud, the seed devices, %.0f s: %d records (%.0f/s); CPU %.1f %% of one core (user %.2f s, sys %.2f s), peak RSS %.1f MiB\n",
            l, w, f, f / w, (u + s) / w * 100, u, s, r / 1024 }'
    grep 'mqtt:' "$work/err" || true
}
measure "sniff --mqtt --ha-discovery --metrics" --mqtt "mqtt://127.0.0.1:$port/bench" \
    --ha-discovery --mqtt-interval 5 --metrics 127.0.0.1:0
measure "sniff alone"
