#!/usr/bin/env bash
# The report page of a large capture stays small: rtuscope_bench_gen's traffic of FRAMES
# frames (the four seed devices with their profiles, and standard devices) made into a
# page, which must be under MAX_BYTES (default 5 MB). Prints the page's size and the time
# it took; docs/performance.md has the figure for 1,000,000 frames.
# Usage: report_size.sh RTUSCOPE RTUSCOPE_BENCH_GEN FRAMES [MAX_BYTES] [DIR]
set -euo pipefail
rtuscope=$1
gen=$2
frames=$3
max=${4:-5000000}
dir=${5:-$(mktemp -d)}
capture=$dir/report-$frames.rtucap
[ -s "$capture" ] || "$gen" --frames "$frames" --capture "$capture" >/dev/null
start=$(date +%s.%N)
"$rtuscope" report "$capture" -o "$dir/report-$frames.html" --device 1=zb-uvi485 \
    --device 2=sensor-analyser --device 3=pdu485 --device 4=zyi-relay
end=$(date +%s.%N)
size=$(stat -c %s "$dir/report-$frames.html")
echo "report of $frames frames: $size bytes in $(awk "BEGIN { printf \"%.1f\", $end - $start }") s"
[ "$size" -le "$max" ] || { echo "FAIL: the page is $size bytes, more than $max" >&2; exit 1; }
