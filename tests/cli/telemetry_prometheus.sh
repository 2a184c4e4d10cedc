#!/usr/bin/env bash
# `--metrics` end to end: a real Prometheus server, started here with a config of its own
# in a temporary directory on a free localhost port, scrapes `rtuscope demo --metrics`;
# its HTTP API then returns the register gauges (the demo's 220.5 V) and the counters.
# Usage: telemetry_prometheus.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
command -v prometheus >/dev/null ||
    { echo "SKIP: prometheus is not installed (scripts/setup installs it)"; exit 77; }
work=$(mktemp -d)
pids=()
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null && wait "$p" 2>/dev/null; done
    rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

"$rtuscope" demo --seconds 40 --metrics 127.0.0.1:0 >/dev/null 2>"$work/demo.err" &
pids+=($!)
for _ in $(seq 50); do grep -q 'metrics on' "$work/demo.err" && break; sleep 0.1; done
target=$(sed -n 's|^rtuscope: metrics on http://\(.*\)/metrics$|\1|p' "$work/demo.err")
[ -n "$target" ] || fail "no metrics address on stderr: $(cat "$work/demo.err")"

port=$(free_port)
cat >"$work/prometheus.yml" <<CONF
global:
  scrape_interval: 1s
scrape_configs:
  - job_name: rtuscope
    static_configs:
      - targets: ['$target']
CONF
prometheus --config.file="$work/prometheus.yml" --storage.tsdb.path="$work/data" \
    --web.listen-address="127.0.0.1:$port" >"$work/prometheus.log" 2>&1 &
pids+=($!)
query() { python3 - "$port" "$1" <<'PY'
import json, sys, urllib.parse, urllib.request
url = "http://127.0.0.1:%s/api/v1/query?query=%s" % (sys.argv[1], urllib.parse.quote(sys.argv[2]))
try:
    data = json.load(urllib.request.urlopen(url, timeout=2))
except Exception:
    sys.exit(1)
for r in data["data"]["result"]:
    print(json.dumps(r["metric"], sort_keys=True), r["value"][1])
PY
}
found=""
for _ in $(seq 150); do
    found=$(query 'rtuscope_register{bus="demo",slave="3",name="voltage"}')
    [ -n "$found" ] && break
    sleep 0.2
done
[ -n "$found" ] || fail "Prometheus has no voltage gauge: $(tail -5 "$work/prometheus.log")"
grep -q ' 220.5$' <<<"$found" || fail "the voltage gauge is not 220.5: $found"
grep -q '"unit": "V"' <<<"$found" || fail "the voltage gauge has not its unit: $found"
query 'up{job="rtuscope"}' | grep -q ' 1$' || fail "Prometheus does not see rtuscope up"
frames=$(query 'sum(rtuscope_frames_total{bus="demo"})')
[ -n "$frames" ] && awk '{ exit !($NF > 0) }' <<<"$frames" || fail "no frames counted: $frames"
echo ok
