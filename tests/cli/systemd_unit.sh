#!/usr/bin/env bash
# contrib's systemd unit runs a command rtuscope accepts: its ExecStart options, read from
# the unit, drive the demo's virtual bus for two seconds in place of the port.
# Usage: systemd_unit.sh RTUSCOPE UNIT_FILE
set -uo pipefail
rtuscope=$1 unit=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
dir=$(mktemp -d) && trap 'rm -rf "$dir"' EXIT

# ExecStart with its continuation lines joined.
exec_start=$(sed -n '/^ExecStart=/,/[^\\]$/p' "$unit" | sed 's/\\$//' | tr '\n' ' ' | sed 's/^ExecStart=//')
read -ra words <<<"$exec_start"
[ "${words[1]:-}" = sniff ] && [ "${words[2]:-}" = /dev/%I ] || fail "ExecStart is not 'rtuscope sniff /dev/%I ...': $exec_start"
options=("${words[@]:3}")
[ ${#options[@]} -gt 4 ] || fail "too few options in ExecStart: $exec_start"

cd "$dir" || exit 1
"$rtuscope" demo --seconds 2 "${options[@]}" >/dev/null 2>err
rc=$?
[ "$rc" -eq 0 ] || fail "the unit's options: exit $rc: $(cat err)"
grep -q '^rtuscope: recorded' err || fail "no recording summary: $(cat err)"
echo "ok"
