#!/usr/bin/env bash
# An output the system refuses (here /dev/full: "No space left on device") ends the run
# with one line on stderr and exit status 1, for every output format, whether the
# refusal comes at the end (a small output, still in stdio's buffer) or mid-run (an
# output larger than that buffer). A full disk must not pass for a complete output.
# Usage: output_write_error.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
[ -w /dev/full ] || { echo "no /dev/full: skipped"; exit 0; }
fail() { echo "FAIL: $*" >&2; exit 1; }
expected='rtuscope: error: cannot write the output: No space left on device'

check() {  # what... : runs rtuscope ARGS with stdout on /dev/full
    local err rc
    err=$("$rtuscope" "$@" 2>&1 >/dev/full)
    rc=$?
    [ "$rc" -eq 1 ] || fail "rtuscope $*: exit status $rc, not 1"
    [ "$err" = "$expected" ] || fail "rtuscope $*: stderr was: $err"
}

small=captures/devices/pdu485.hex
check decode "$small"
check decode "$small" --csv
check decode "$small" --jsonl
check decode "$small" --values-csv --device 1=pdu485
check stats "$small"
check stats "$small" --csv
# A live run owns threads (the virtual bus, its devices, the master): they are stopped and
# joined on the error's way out, not left to abort the process.
check demo --seconds 1
check demo --seconds 1 --csv

# Far more than stdout's 64 KiB buffer: the refusal comes while records are still being
# decoded (the same capture 200 times over, ~2.3 MB of JSON Lines).
big=$(mktemp)
trap 'rm -f "$big"' EXIT
for _ in $(seq 200); do cat "$small"; done >"$big"
[ "$("$rtuscope" decode "$big" --jsonl --device 1=pdu485 | wc -c)" -gt 2000000 ] ||
    fail "the large output is not larger than stdio's buffer"
check decode "$big" --jsonl --device 1=pdu485
check decode "$big"
check decode "$big" --csv
echo "ok"
