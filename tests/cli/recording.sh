#!/usr/bin/env bash
# A long run's recording: files by the clock, SIGUSR1 starting the next file, decoded
# together as the live run showed the line; SIGHUP ending a run as SIGTERM does; rotation
# options without -w refused.
# Usage: recording.sh RTUSCOPE
set -uo pipefail
rtuscope=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
records() { grep -E '^ *[0-9]+ [0-9:.]+ ' "$1"; }

"$rtuscope" demo --no-color --seconds 4 -w "$dir/bus.rtucap" --rotate-seconds 1 \
    >"$dir/live" 2>"$dir/live.err" &
pid=$!
sleep 2.5
kill -USR1 "$pid"
wait "$pid" || fail "demo: $(cat "$dir/live.err")"
files=("$dir"/bus-*.rtucap)
[ ${#files[@]} -ge 5 ] || fail "${#files[@]} files for 4 s by the second and a SIGUSR1: ${files[*]}"
for f in "${files[@]}"; do
    [[ $(basename "$f") =~ ^bus-20[0-9]{6}T[0-9]{6}Z(_[0-9]{3})?\.rtucap$ ]] || fail "file name $f"
    head -1 "$f" | grep -qx '# rtuscope capture v1' || fail "$f has no header"
done
ls "$dir" | grep -q '_002\.rtucap$' || fail "no second file within a second after SIGUSR1: $(ls "$dir")"
grep -q "recorded ${#files[@]} files, the last" "$dir/live.err" || fail "no recording summary: $(cat "$dir/live.err")"
"$rtuscope" decode --no-color "$dir/bus-*.rtucap" >"$dir/later" 2>"$dir/later.err" ||
    fail "decode of the files: $(cat "$dir/later.err")"
[ "$(records "$dir/live" | wc -l)" -gt 20 ] || fail "too few records live"
diff <(records "$dir/live") <(records "$dir/later") >"$dir/diff" ||
    fail "the files decode otherwise than the live run showed: $(head "$dir/diff")"

# SIGKILL on compressed files: every file decodes, each from its header on, and together
# they are what the live run showed but for the last block's 2 s (and the frames then
# still awaiting an answer).
"$rtuscope" demo --no-color -w "$dir/kill.rtucap.zst" --rotate-seconds 2 >"$dir/kill.live" 2>/dev/null &
pid=$!
sleep 5
{ kill -KILL "$pid"; wait "$pid"; } 2>/dev/null  # bash reports the killed job on stderr
zfiles=("$dir"/kill-*.rtucap.zst)
[ ${#zfiles[@]} -ge 2 ] || fail "${#zfiles[@]} compressed files for 5 s by 2 s"
for f in "${zfiles[@]}"; do
    "$rtuscope" decode "$f" >/dev/null 2>"$dir/one.err" || fail "$f alone: $(cat "$dir/one.err")"
done
"$rtuscope" decode --no-color "$dir/kill-*.rtucap.zst" >"$dir/kill.later" 2>"$dir/kill.err" ||
    fail "decode of the killed run's files: $(cat "$dir/kill.err")"
live_n=$(records "$dir/kill.live" | wc -l)
later_n=$(records "$dir/kill.later" | wc -l)
[ "$later_n" -gt 10 ] || fail "only $later_n records decode of a killed run"
[ "$later_n" -ge $((live_n - 45)) ] || fail "$later_n records decode of $live_n live: more than the last block lost"
diff <(records "$dir/kill.later" | head -n $((later_n - 2))) <(records "$dir/kill.live" | head -n $((later_n - 2))) \
    >"$dir/kill.diff" || fail "the killed run's files decode otherwise: $(head "$dir/kill.diff")"

# SIGHUP: a clean stop, the capture ended with its stop line.
"$rtuscope" demo --no-color -w "$dir/hup.rtucap" >"$dir/hup.out" 2>"$dir/hup.err" &
pid=$!
sleep 1.5
kill -HUP "$pid"
rc=0; wait "$pid" || rc=$?
[ "$rc" -eq 0 ] || fail "exit status $rc after SIGHUP: $(cat "$dir/hup.err")"
grep -q '^rtuscope: [0-9]* frames' "$dir/hup.err" || fail "no summary after SIGHUP"
[ "$(tail -1 "$dir/hup.rtucap")" = "# stopped (the live run ended here)" ] ||
    fail "the capture does not end with the stop after SIGHUP"

# Triggers: only windows around the master's writes to slave 3, each a file that decodes
# alone and holds its events; the summary counts them.
"$rtuscope" demo --no-color --seconds 6 -w "$dir/win.rtucap" --trigger 'slave=3,function=6' \
    --pre 0.5 --post 0.5 >"$dir/win.live" 2>"$dir/win.err" || fail "demo with a trigger: $(cat "$dir/win.err")"
wfiles=("$dir"/win-*.rtucap)
[ -e "${wfiles[0]}" ] || fail "no window written: $(cat "$dir/win.err")"
events=$(cat "${wfiles[@]}" | grep -c '^# event: record [0-9]* fired slave=3,function=6$')
grep -q "; $events trigger events, ${#wfiles[@]} windows\?$" "$dir/win.err" ||
    fail "summary does not count $events events in ${#wfiles[@]} windows: $(tail -1 "$dir/win.err")"
for f in "${wfiles[@]}"; do
    "$rtuscope" decode --no-color "$f" >"$dir/w.out" 2>"$dir/w.err" || fail "$f: $(cat "$dir/w.err")"
    grep -qE '^ *[0-9]+ [0-9:.]+ +3 ▶ Write Single Register' "$dir/w.out" || fail "$f holds no write to slave 3"
done
rc=0; "$rtuscope" demo --seconds 1 -w "$dir/x.rtucap" --trigger 'slvae=3' >/dev/null 2>"$dir/opt.err" || rc=$?
[ "$rc" -eq 2 ] || fail "a mistyped trigger: exit $rc"
grep -q 'column 1: unknown term "slvae" (did you mean slave?)' "$dir/opt.err" || fail "$(cat "$dir/opt.err")"
rc=0; "$rtuscope" demo --seconds 1 --trigger 'slave=3' >/dev/null 2>"$dir/opt.err" || rc=$?
[ "$rc" -eq 2 ] || fail "--trigger without -w: exit $rc"

# Rotation needs a file to rotate.
rc=0; "$rtuscope" demo --seconds 1 --rotate-seconds 60 >/dev/null 2>"$dir/opt.err" || rc=$?
[ "$rc" -eq 2 ] || fail "--rotate-seconds without -w: exit $rc"
grep -q 'need -w FILE' "$dir/opt.err" || fail "unclear error: $(cat "$dir/opt.err")"
echo "ok"
