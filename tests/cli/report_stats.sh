#!/usr/bin/env bash
# The figures in the report page are the figures `rtuscope stats --jsonl` prints for the
# same input and options: the page embeds them byte for byte (a "<" written \u003c, so
# that no name can end the script element), and its glance and tables read them there.
# Usage: report_stats.sh RTUSCOPE
set -uo pipefail
rtuscope=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

embedded() {  # PAGE: the JSON Lines block of the page, "<" restored
    sed -n '/<script type="application\/jsonl" id="stats-jsonl">/,/<\/script>/p' "$1" |
        sed '1d; $d' | sed 's/\\u003c/</g'
}
same() {  # NAME ARGS...: the page's figures and stats' for the same arguments
    local name=$1; shift
    "$rtuscope" report "$@" -o "$dir/$name.html" 2>"$dir/$name.err" || fail "$name: report: $(cat "$dir/$name.err")"
    "$rtuscope" stats --jsonl "$@" >"$dir/$name.jsonl" 2>"$dir/$name.stats.err" ||
        fail "$name: stats: $(cat "$dir/$name.stats.err")"
    [ -s "$dir/$name.jsonl" ] || fail "$name: stats printed nothing"
    embedded "$dir/$name.html" >"$dir/$name.embedded"
    diff "$dir/$name.jsonl" "$dir/$name.embedded" >"$dir/$name.diff" ||
        fail "$name: the page's figures differ from stats --jsonl: $(head -5 "$dir/$name.diff")"
    grep -q '"frames":[1-9]' "$dir/$name.embedded" || fail "$name: no frames in the page's figures"
}

same demo captures/demo/seed_bus.rtucap
same demo_slave_3 captures/demo/seed_bus.rtucap --slave 3
same demo_late captures/demo/seed_bus.rtucap --from +10 --timeout 0.01
same bad_crc captures/framing/bad_crc.rtucap
same flowmeter captures/realdata/flowmeter_target_15liter_per_min.rtucap
same pdu_untimed captures/devices/pdu485.hex --bus captures/devices/pdu485.bus.toml
same pcap captures/pcaps/mergecap_mixed.pcapng
# A name with "</script>" in it ends no element: the page still parses to the figures.
mkdir "$dir/a<"
cp captures/framing/bad_crc.rtucap "$dir/a</script>b.rtucap"
same script_name "$dir/a</script>b.rtucap"
[ "$(grep -o '</script>' "$dir/script_name.html" | wc -l)" -eq 4 ] || fail "a </script> of the file's name is in the page"
echo ok
