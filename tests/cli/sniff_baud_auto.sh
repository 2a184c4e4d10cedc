#!/usr/bin/env bash
# `sniff PORT --baud auto` on a seed bus at 38400 8N1: the detection's verdict on stderr,
# then the sniff at what it chose, every frame with a valid CRC, and `-w` records the
# settings chosen; `watch --baud auto` likewise. `detect PORT` gives the rate and the
# command line to use.
# Usage: sniff_baud_auto.sh RTUSCOPE SEED_BUS   (from the source directory)
set -uo pipefail
rtuscope=$1
seed_bus=$2
work=$(mktemp -d)
fail() { echo "FAIL: $*" >&2; exit 1; }

# The bus runs while its standard input stays open.
mkfifo "$work/hold"
"$seed_bus" 38400 8N1 <"$work/hold" >"$work/port" 2>"$work/bus.err" &
bus=$!
exec 3>"$work/hold"
trap 'exec 3>&-; wait "$bus"; rm -rf "$work"' EXIT
for _ in $(seq 50); do [ -s "$work/port" ] && break; sleep 0.1; done
port=$(head -1 "$work/port")
[ -n "$port" ] || fail "the bus did not start: $(cat "$work/bus.err")"

"$rtuscope" detect "$port" --bauds 9600,38400 >"$work/detect" 2>"$work/detect.err" ||
    fail "detect: $(cat "$work/detect" "$work/detect.err")"
# The pseudo-terminal carries no parity: the formats of 38400 baud may read the bus alike
# (where the reads are too coarse to time characters), and any of them decodes it.
chosen=$(sed -n "s|^Use: rtuscope sniff $port --baud \(38400\) --format \(8[NEO][12]\)$|\1 \2|p" \
    "$work/detect")
[ -n "$chosen" ] || fail "detect chose otherwise: $(cat "$work/detect")"
grep -q "^Best: $chosen (confidence [a-z]*): " "$work/detect" || fail "no verdict: $(cat "$work/detect")"

"$rtuscope" sniff "$port" --baud auto --seconds 2 --csv -w "$work/line.rtucap" \
    >"$work/sniff.csv" 2>"$work/sniff.err" || fail "sniff: $(cat "$work/sniff.err")"
auto=$(sed -n 's/^rtuscope: note: Best: \(38400 8[NEO][12]\) (confidence [a-z]*): .*/\1/p' \
    "$work/sniff.err")
[ -n "$auto" ] || fail "no verdict on stderr: $(cat "$work/sniff.err")"
grep -q "^# serial $auto\$" "$work/line.rtucap" ||
    fail "the capture header does not say $auto: $(head -3 "$work/line.rtucap")"
frames=$(grep -c ',request,\|,response,' "$work/sniff.csv")
[ "$frames" -ge 4 ] || fail "only $frames frames sniffed: $(head "$work/sniff.csv")"
# The first record may be the end of a frame the sniffer joined in the middle of.
bad=$(tail -n +3 "$work/sniff.csv" | grep -c ',bad,' || true)
[ "$bad" -eq 0 ] || fail "$bad frames with a bad CRC at the settings chosen"
# watch detects before its display starts: the tables show the line chosen.
"$rtuscope" watch "$port" --baud auto --plain --seconds 2 >"$work/watch" 2>"$work/watch.err" ||
    fail "watch: $(cat "$work/watch.err")"
watched=$(sed -n 's/^rtuscope: note: Best: \(38400 8[NEO][12]\) (confidence [a-z]*): .*/\1/p' \
    "$work/watch.err")
[ -n "$watched" ] || fail "watch gave no verdict: $(cat "$work/watch.err")"
grep -q "^bus: $watched, " "$work/watch" || fail "watch's tables: $(head -3 "$work/watch")"
echo "ok"
