#!/usr/bin/env bash
# --pcapng: a capture decoded to pcapng and decoded again gives the same records (times,
# directions, notes, pairing) and its line; tshark shows the direction flags and the
# comments and filters on them; --from/--to cut the file as they cut the text; a comment
# someone adds is shown under its frame and kept in a pcapng written again; an output
# that cannot be created is a one-line error.
# Usage: pcapng_output.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v tshark >/dev/null || fail "tshark is missing (Debian: apt-get install tshark)"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
tap=captures/taps/write_retry.rtucap

# Round trip, at a line the capture header does not give (the pcapng must carry it).
"$rtuscope" decode "$tap" --baud 19200 --pcapng "$dir/a.pcapng" --no-color >"$dir/a.txt" 2>/dev/null ||
    fail "decode --pcapng failed"
"$rtuscope" decode "$dir/a.pcapng" --no-color >"$dir/b.txt" || fail "decoding the pcapng failed"
grep -q '19200 8N1' <(head -1 "$dir/b.txt") || fail "the line is not read back: $(head -1 "$dir/b.txt")"
diff <(tail -n +2 "$dir/a.txt") <(tail -n +2 "$dir/b.txt") || fail "the records differ read back"
grep -q 'no answer before the next request' "$dir/b.txt" || fail "no note in the records"
# From a pipe, the same.
"$rtuscope" decode - --no-color <"$dir/a.pcapng" >"$dir/p.txt" || fail "decoding from a pipe failed"
diff <(tail -n +2 "$dir/a.txt") <(tail -n +2 "$dir/p.txt") || fail "the records differ from a pipe"
grep -q '19200 8N1' <(head -1 "$dir/p.txt") || fail "no line from a pipe: $(head -1 "$dir/p.txt")"

# tshark: the flags and the comments (record numbers, pairing, note ids).
v=$(tshark -r "$dir/a.pcapng" -V 2>/dev/null)
grep -q 'Direction: Outbound (0x2)' <<<"$v" || fail "tshark -V shows no outbound flag"
grep -q 'Direction: Inbound (0x1)' <<<"$v" || fail "tshark -V shows no inbound flag"
grep -q 'Interface description: 19200 8N1' <<<"$v" || fail "tshark -V shows no line"
grep -q 'rtuscope #2 request: answered by #3' <<<"$v" || fail "tshark -V shows no request comment"
grep -q 'rtuscope #3 response: 15.83 ms after #2' <<<"$v" || fail "tshark -V shows no answer comment"
# Requests outbound, answers inbound, as the port tags say (to and from 502).
fields=$(tshark -r "$dir/a.pcapng" -T fields -e frame.packet_flags_direction -e exported_pdu.dst_port 2>/dev/null)
[ "$fields" = $'0x00000002\t502\n0x00000002\t502\n0x00000001\t49152\n0x00000002\t502\n0x00000001\t49152' ] ||
    fail "flags and ports: $fields"
filtered=$(tshark -r "$dir/a.pcapng" -Y 'frame.comment contains "txn.no_answer"' -T fields -e frame.number 2>/dev/null)
[ "$filtered" = "1" ] || fail "filtering on the note id gives: $filtered"

# Values decoded by a profile go into the comment as the text shows them.
"$rtuscope" decode captures/devices/pdu485.hex --bus captures/devices/pdu485.bus.toml \
    --pcapng "$dir/v.pcapng" --no-color >"$dir/v.txt" || fail "decode with a bus failed"
value=$(grep -m1 -o '[a-z_]* *= [^(]*(raw 0x[0-9A-F]*)' "$dir/v.txt" | sed 's/  */ /g')
[ -n "$value" ] || fail "no value in the text"
tshark -r "$dir/v.pcapng" -T fields -e frame.comment 2>/dev/null | grep -qF "$value" ||
    fail "the value \"$value\" is in no comment"

# --from/--to: the pcapng holds the records the text shows.
"$rtuscope" decode "$tap" --from 08:00:00.4 --to 08:00:00.55 -t e --pcapng "$dir/cut.pcapng" \
    --no-color >"$dir/cut.txt" || fail "decode --from --to failed"
text_times=$(awk '/^ *[0-9]+ [0-9]/ { print $2 }' "$dir/cut.txt" | tr '\n' ' ')
pcapng_times=$(tshark -r "$dir/cut.pcapng" -T fields -e frame.time_epoch 2>/dev/null |
    awk '{ printf "%.6f ", $1 }')
[ "$text_times" = "1763798400.491667 1763798400.511667 " ] || fail "the text cut holds: $text_times"
[ "$pcapng_times" = "$text_times" ] || fail "the pcapng cut holds: $pcapng_times"

# A comment someone adds (editcap, as Wireshark would) is shown and written again.
editcap -a '3:reset here, says the vendor' "$dir/a.pcapng" "$dir/c.pcapng" 2>/dev/null ||
    fail "editcap failed"
"$rtuscope" decode "$dir/c.pcapng" --pcapng "$dir/d.pcapng" --no-color >"$dir/c.txt" ||
    fail "decoding the commented file failed"
grep -A1 '15.83 ms after #2' "$dir/c.txt" | grep -q '^ *# reset here, says the vendor$' ||
    fail "the comment is not under its frame: $(cat "$dir/c.txt")"
[ "$(grep -c '^ *#' "$dir/c.txt")" = 1 ] || fail "rtuscope's own comments are shown again"
tshark -r "$dir/d.pcapng" -T fields -e frame.comment 2>/dev/null | sed -n 3p |
    grep -q '^rtuscope #3 response: 15.83 ms after #2,reset here, says the vendor$' ||
    fail "the comment is not written again"

# An output that cannot be created: one line, exit 1, nothing written.
err=$("$rtuscope" decode "$tap" --pcapng "$dir/no/such/dir/x.pcapng" 2>&1 >/dev/null)
rc=$?
[ "$rc" -eq 1 ] || fail "bad output path: exit status $rc"
[ "$err" = "rtuscope: error: $dir/no/such/dir/x.pcapng: cannot create the pcapng: No such file or directory" ] ||
    fail "bad output path: $err"
# A full disk is an error after the run, as for --pcap.
if [ -w /dev/full ]; then
    err=$("$rtuscope" decode "$tap" --pcapng /dev/full 2>&1 >/dev/null)
    rc=$?
    [ "$rc" -eq 1 ] || fail "/dev/full: exit status $rc"
    [ "$err" = "rtuscope: error: /dev/full: cannot write the pcapng: No space left on device" ] ||
        fail "/dev/full: $err"
fi
echo ok
