#!/usr/bin/env bash
# The report page in a real browser (headless Chromium), loaded from disk with the
# network off: no JavaScript error, every chart drawn (the page counts them on <body
# data-charts data-drawn> and sets data-all-drawn once each has drawn), and a screenshot
# that is no blank page. Exit 77 (ctest: skipped) only when Chromium is missing or cannot
# start at all.
# Usage: report_browser.sh RTUSCOPE
set -uo pipefail
rtuscope=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

browser=""
for name in chromium chromium-browser; do
    if command -v "$name" >/dev/null; then browser=$name; break; fi
done
[ -n "$browser" ] || { echo "SKIP: no chromium (scripts/setup installs it)"; exit 77; }
# As root, and in a network namespace of its own where that can be made: nothing the
# page needs may come from the network.
wrap=()
if [ "$(id -u)" -eq 0 ] && unshare -n true 2>/dev/null; then wrap=(unshare -n); fi
run_browser() {
    "${wrap[@]}" timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-quic \
        --no-first-run --disable-background-networking --disable-component-update \
        --disable-sync --user-data-dir="$(mktemp -d -p "$dir")" --enable-logging=stderr --v=0 \
        --hide-scrollbars --virtual-time-budget=10000 "$@"
}
echo '<!DOCTYPE html><html><body></body></html>' >"$dir/blank.html"
run_browser --window-size=1200,1600 --screenshot="$dir/blank.png" "file://$dir/blank.html" \
    >/dev/null 2>"$dir/blank.err"
[ -s "$dir/blank.png" ] || { echo "SKIP: $browser cannot start: $(tail -3 "$dir/blank.err")"; exit 77; }

check_page() {  # NAME RTUSCOPE-ARGS...
    local name=$1; shift
    "$rtuscope" report "$@" -o "$dir/$name.html" 2>"$dir/$name.make.err" ||
        fail "$name: report: $(cat "$dir/$name.make.err")"
    run_browser --dump-dom "file://$dir/$name.html" >"$dir/$name.dom" 2>"$dir/$name.err" ||
        fail "$name: $browser --dump-dom: $(tail -3 "$dir/$name.err")"
    if grep -E "Uncaught|SyntaxError|TypeError|ReferenceError" "$dir/$name.err" >"$dir/$name.js-errors"; then
        fail "$name: JavaScript error: $(head -3 "$dir/$name.js-errors")"
    fi
    local body charts drawn
    body=$(grep -o '<body[^>]*>' "$dir/$name.dom" | head -1)
    charts=$(sed -n 's/.*data-charts="\([0-9]*\)".*/\1/p' <<<"$body")
    drawn=$(sed -n 's/.*data-drawn="\([0-9]*\)".*/\1/p' <<<"$body")
    [ "${charts:-0}" -ge "$min_charts" ] || fail "$name: ${charts:-no} charts, expected at least $min_charts: $body"
    [ "$drawn" = "$charts" ] || fail "$name: $drawn of $charts charts drawn: $body"
    grep -q 'data-all-drawn="yes"' <<<"$body" || fail "$name: the page did not finish drawing: $body"
    run_browser --window-size=1200,1600 --screenshot="$dir/$name.png" "file://$dir/$name.html" \
        >/dev/null 2>"$dir/$name.shot.err"
    local size blank
    size=$(stat -c %s "$dir/$name.png" 2>/dev/null || echo 0)
    blank=$(stat -c %s "$dir/blank.png")
    [ "$size" -gt $((blank * 10)) ] ||
        fail "$name: the screenshot ($size bytes) is no more than a blank page's ($blank bytes)"
}

# The demo's recording: four slaves with profiles, values charted, writes marked.
min_charts=12
check_page demo captures/demo/seed_bus.rtucap
grep -q 'id="slave-3"' "$dir/demo.dom" || fail "demo: no card for slave 3"
grep -q 'in V' "$dir/demo.dom" || fail "demo: no chart of the PDU's voltage in V"
grep -q 'id="record-' "$dir/demo.dom" || fail "demo: no flagged record listed"
# Bad CRCs: errors on the timeline, the flagged records linked to their time.
min_charts=2
check_page bad_crc captures/framing/bad_crc.rtucap
grep -q 'class="time" href="#timeline"' "$dir/bad_crc.dom" || fail "bad_crc: no flagged record links to the timeline"
grep -q 'frame.crc_mismatch' "$dir/bad_crc.dom" || fail "bad_crc: the CRC note is not listed"
echo ok
