#!/usr/bin/env bash
# The dashboard in a real terminal: `watch --demo` inside tmux (a server of the test's
# own, a window of known size), keys sent, the screen read back.
# Usage: watch_dashboard.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$(realpath "$1")
work=$(mktemp -d)
socket="rtuscope-watch-$$"
tmux_() { tmux -L "$socket" "$@"; }
trap 'tmux_ kill-server 2>/dev/null; rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; echo "--- screen:" >&2; tmux_ capture-pane -p >&2; exit 1; }
# Waits up to 15 s for the screen to match the regular expression.
wait_for() {
    for _ in $(seq 150); do
        tmux_ capture-pane -p | grep -Eq "$1" && return 0
        sleep 0.1
    done
    return 1
}

tmux_ -f /dev/null new-session -d -x 120 -y 40 \
    "cd '$work' && LANG=C.UTF-8 '$rtuscope' watch --demo; echo \"exit=\$?\" > '$work/rc'; sleep 60"
wait_for '^ +1 zb-uvi485 ' || fail "slave 1 never shown"
wait_for 'uv_intensity +616\.8 µW/cm²' || fail "the UV transmitter's value never shown"
wait_for '^ +4 zyi-relay ' || fail "slave 4 never shown"
# Down twice: slave 3, the PDU; Enter opens its registers.
tmux_ send-keys Down Down Enter
wait_for '^slave 3 \(pdu485\)' || fail "selecting slave 3 does not show its registers"
wait_for 'voltage +220\.5 V' || fail "the PDU's voltage never shown"
# The master writes the PDU's voltage alarm threshold: the written column says when.
wait_for 'voltage_high_alarm +[0-9.]+ V +[0-9.]+ s +[0-9.]+ (s|min) ' ||
    fail "the master's write is not shown"
# A snapshot to a file.
tmux_ send-keys f
wait_for 'snapshot written to rtuscope-snapshot-' || fail "no snapshot message"
ls "$work"/rtuscope-snapshot-*.txt >/dev/null 2>&1 || fail "no snapshot file"
grep -q '^slave 3 (pdu485):' "$work"/rtuscope-snapshot-*.txt || fail "the snapshot lacks the PDU"
# 80x24: every slave still shows its address, profile and answered share.
tmux_ resize-window -x 80 -y 24
sleep 0.5
for slave in "1 zb-uvi485" "2 sensor-analys" "3 pdu485" "4 zyi-relay"; do
    wait_for "^ +$slave[^ ]* +[0-9.]+ +[0-9.]+ %" || fail "at 80x24, no line for slave $slave"
done
tmux_ send-keys q
for _ in $(seq 100); do [ -s "$work/rc" ] && break; sleep 0.1; done
[ "$(cat "$work/rc" 2>/dev/null)" = "exit=0" ] || fail "q: $(cat "$work/rc" 2>/dev/null)"
echo "ok"
