#!/usr/bin/env bash
# Ctrl-C (SIGINT) or SIGTERM during a decode stops it at a record boundary: the text ends
# with its summary, the CSV with a whole row, the --pcap file is closed and reads back, and
# the exit status is the shell's for the signal (130, 143). The input is a pipe held open
# after a long capture, so the signal comes while rtuscope decodes or waits for more.
# Usage: stop_decode.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

for _ in $(seq 2000); do cat captures/devices/pdu485.hex; done >"$work/big.hex"

stop() {  # SIGNAL STATUS OPTIONS...: decodes the pipe, sends SIGNAL, expects STATUS
    local signal=$1 status=$2
    shift 2
    rm -f "$work/pipe"
    mkfifo "$work/pipe"
    "$rtuscope" decode "$work/pipe" --input-format hex "$@" --pcap "$work/out.pcap" \
        >"$work/out" 2>"$work/err" &
    local pid=$!
    exec 3>"$work/pipe"  # held open after the capture: more could come
    cat "$work/big.hex" >&3
    sleep 0.5
    kill "-$signal" "$pid"
    for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$pid" 2>/dev/null; then
        kill -9 "$pid"
        exec 3>&-
        fail "$signal $*: rtuscope still runs 10 s after the signal"
    fi
    wait "$pid"
    local rc=$?
    exec 3>&-
    [ "$rc" -eq "$status" ] || fail "$signal $*: exit status $rc, not $status ($(cat "$work/err"))"
    [ ! -s "$work/err" ] || fail "$signal $*: stderr: $(cat "$work/err")"
    [ "$(tail -c 1 "$work/out" | od -An -c | tr -d ' ')" = '\n' ] ||
        fail "$signal $*: the output does not end with a whole line"
    "$rtuscope" decode "$work/out.pcap" --csv >"$work/again" 2>"$work/again.err" ||
        fail "$signal $*: the pcap does not read back: $(cat "$work/again.err")"
    [ "$(wc -l <"$work/again")" -gt 1000 ] || fail "$signal $*: the pcap holds no frames"
}

stop INT 130 --no-color
tail -1 "$work/out" | grep -q '^-- CRC: ' || fail "the text does not end with its summary"
stop TERM 143 --csv
awk -F, 'NR > 1 && $1 != NR - 1 { exit 1 }' "$work/out" || fail "the CSV's rows are not whole"
echo "ok"
