#!/usr/bin/env bash
# Compressed inputs: a capture, a hex log and a pcap written in blocks by OutputFile
# (rtuscope_bench_compress) as .zst and .gz decode as the plain file does, from the file
# and from standard input; a file cut off inside a block decodes its whole blocks and ends
# with a note naming the file; a corrupt one is a one-line error naming it, exit status 1.
# Usage: compressed_input.sh RTUSCOPE COMPRESS   (from the source directory)
set -uo pipefail
rtuscope=$1
compress=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

capture=captures/realdata/flowmeter_target_15liter_per_min.rtucap
for input in "$capture" captures/seeds/pdu485.hex captures/pcaps/modbus_tcp.pcap; do
    base=$(basename "$input")
    "$rtuscope" decode "$input" --csv >"$work/plain.csv" 2>"$work/plain.err" ||
        fail "$input: the plain file does not decode"
    "$rtuscope" decode "$input" >"$work/plain.txt" 2>/dev/null
    for ext in zst gz; do
        packed=$work/$base.$ext
        "$compress" "$input" --out "$packed" --block-bytes 512 >/dev/null ||
            fail "$packed: cannot write"
        "$rtuscope" decode "$packed" --csv >"$work/file.csv" 2>"$work/file.err" ||
            fail "$packed: exit status $? ($(cat "$work/file.err"))"
        cmp -s "$work/plain.csv" "$work/file.csv" || fail "$packed: another CSV than $input's"
        sed "s|$packed:|$input:|" "$work/file.err" | cmp -s "$work/plain.err" - ||
            fail "$packed: another stderr than $input's"
        "$rtuscope" decode - --csv <"$packed" >"$work/stdin.csv" 2>/dev/null ||
            fail "$packed on stdin: exit status $?"
        cmp -s "$work/plain.csv" "$work/stdin.csv" || fail "$packed on stdin: another CSV"
        # The text names its input on its first line.
        "$rtuscope" decode "$packed" | sed "1s|^$packed:|$input:|" >"$work/file.txt"
        cmp -s "$work/plain.txt" "$work/file.txt" || fail "$packed: another text than $input's"
    done
done

# Cut off inside a block, as a killed run leaves it: the whole blocks, then a note.
"$rtuscope" decode "$capture" --csv >"$work/plain.csv"
for ext in zst gz; do
    packed=$work/cut.rtucap.$ext
    "$compress" "$capture" --out "$packed" --block-bytes 2048 >/dev/null
    size=$(stat -c %s "$packed")
    head -c $((size * 2 / 3)) "$packed" >"$work/cut"
    mv "$work/cut" "$packed"
    "$rtuscope" decode "$packed" --csv >"$work/cut.csv" 2>"$work/cut.err" ||
        fail "$packed cut off: exit status $? ($(cat "$work/cut.err"))"
    grep -qE "^rtuscope: note: $packed: the file ends inside a (zstd frame|gzip member) \(cut off before it was complete: a run killed or still being written\); the [0-9]+ complete (frames|members) before it are read$" \
        "$work/cut.err" || fail "$packed cut off: stderr: $(cat "$work/cut.err")"
    rows=$(wc -l <"$work/cut.csv")
    [ "$rows" -gt 10 ] && [ "$rows" -lt "$(wc -l <"$work/plain.csv")" ] ||
        fail "$packed cut off: $rows rows"
    # The records before the cut are the plain file's, but the last (its answer may lie
    # past the cut).
    head -n $((rows - 1)) "$work/plain.csv" | cmp -s - <(head -n $((rows - 1)) "$work/cut.csv") ||
        fail "$packed cut off: other records than the plain file's"
    "$rtuscope" decode - <"$packed" | tail -n 1 | grep -q "^-- note: the file ends inside a" ||
        fail "$packed cut off, on stdin: no note at the end of the text"

    # A byte changed in the middle: one line on stderr naming the file, exit status 1.
    packed=$work/corrupt.rtucap.$ext
    "$compress" "$capture" --out "$packed" --block-bytes 2048 >/dev/null
    size=$(stat -c %s "$packed")
    printf '\xA5' | dd of="$packed" bs=1 seek=$((size / 2)) conv=notrunc status=none
    "$rtuscope" decode "$packed" >"$work/out" 2>"$work/err"
    rc=$?
    [ "$rc" -eq 1 ] || fail "$packed corrupt: exit status $rc"
    [ "$(wc -l <"$work/err")" -eq 1 ] || fail "$packed corrupt: stderr: $(cat "$work/err")"
    grep -qE "^rtuscope: error: $packed: corrupt (zstd|gzip) data near byte [0-9]+ of the file \([0-9]+ complete (frames|members) before it\): " \
        "$work/err" || fail "$packed corrupt: stderr: $(cat "$work/err")"
    "$rtuscope" decode - <"$packed" >/dev/null 2>"$work/err"
    rc=$?
    [ "$rc" -eq 1 ] && grep -q "^rtuscope: error: -: corrupt" "$work/err" ||
        fail "$packed corrupt, on stdin: exit status $rc, stderr: $(cat "$work/err")"
done
echo ok
