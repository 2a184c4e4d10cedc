#!/usr/bin/env bash
# `profiles infer` on a sample capture: the draft passes `profiles check`, `decode
# --profile` uses it at once (its reg_0x... names in the values), -o writes one file per
# slave that --profile-dir reads back, and a capture of several slaves needs --slave or -o.
# Usage: profiles_infer.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

capture=captures/realdata/flowmeter_target_15liter_per_min.rtucap
"$rtuscope" profiles infer "$capture" >"$work/draft.toml" 2>"$work/err" ||
    fail "infer: $(cat "$work/err")"
grep -q '^name = "slave-247"$' "$work/draft.toml" || fail "no profile of slave 247"
grep -q '^type = "f32"$' "$work/draft.toml" || fail "no f32 found"
"$rtuscope" profiles check "$work/draft.toml" >"$work/check" 2>&1 ||
    fail "check: $(cat "$work/check")"
"$rtuscope" decode "$capture" --profile "$work/draft.toml" --no-color >"$work/decoded" 2>&1 ||
    fail "decode: $(cat "$work/decoded")"
grep -q 'reg_0x0002 *= ' "$work/decoded" || fail "decode does not show reg_0x0002"

two=captures/devices/pdu485.hex
"$rtuscope" profiles infer "$two" >/dev/null 2>"$work/err"
[ $? -eq 2 ] || fail "several slaves without --slave or -o should exit 2"
"$rtuscope" profiles infer "$two" --slave 1 >"$work/one.toml" 2>"$work/err" ||
    fail "--slave 1: $(cat "$work/err")"
grep -q '^addresses = \[1, 1\]$' "$work/one.toml" || fail "--slave 1 gave another slave"
"$rtuscope" profiles infer "$two" -o "$work/drafts" >"$work/list" 2>"$work/err" ||
    fail "-o: $(cat "$work/err")"
[ -f "$work/drafts/slave-1.toml" ] || fail "-o wrote no slave-1.toml"
"$rtuscope" profiles check "$work"/drafts/*.toml >/dev/null 2>"$work/err" ||
    fail "check of -o: $(cat "$work/err")"
"$rtuscope" decode "$two" --profile-dir "$work/drafts" --no-color >"$work/decoded2" 2>&1 ||
    fail "decode --profile-dir: $(cat "$work/decoded2")"
grep -q 'slave-1 on 1' "$work/decoded2" || fail "the drafts are not on their slaves"

for i in $(seq 1 100); do printf '\x55\xaa\x13'; done >"$work/garbage.bin"
"$rtuscope" profiles infer "$work/garbage.bin" --input-format raw >/dev/null 2>"$work/err"
[ $? -eq 1 ] || fail "garbage should exit 1"
grep -q 'no answered reads' "$work/err" || fail "garbage: $(cat "$work/err")"
[ "$(wc -l <"$work/err")" -eq 1 ] || fail "garbage: more than one line"
"$rtuscope" profiles infer "$capture" --slave 300 >/dev/null 2>&1
[ $? -eq 2 ] || fail "--slave 300 should exit 2"
echo "ok"
