#!/usr/bin/env bash
# `--mqtt` end to end against a real mosquitto broker started here, on a free localhost
# port with a config of its own: the demo's values arrive retained with their units, Home
# Assistant gets its discovery documents, the sniffer's availability goes offline when it
# stops and when it is killed (its last will), a wrong password is one line and the run
# goes on (or exits 1 with --mqtt-required).
# Usage: telemetry_mqtt.sh RTUSCOPE   (from the source directory)
set -uo pipefail
rtuscope=$1
for tool in /usr/sbin/mosquitto mosquitto_sub mosquitto_passwd; do
    command -v "$tool" >/dev/null || { echo "SKIP: $tool is not installed (scripts/setup installs mosquitto and mosquitto-clients)"; exit 77; }
done
work=$(mktemp -d)
broker=""
cleanup() {
    [ -n "$broker" ] && kill "$broker" 2>/dev/null && wait "$broker" 2>/dev/null
    rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
port=$(free_port)
mosquitto_passwd -b -c "$work/passwords" field secret 2>/dev/null || fail "mosquitto_passwd"
chmod 0644 "$work/passwords"
cat > "$work/mosquitto.conf" <<CONF
listener $port 127.0.0.1
allow_anonymous true
password_file $work/passwords
persistence false
$( [ "$(id -u)" -eq 0 ] && echo "user root" )
CONF
/usr/sbin/mosquitto -c "$work/mosquitto.conf" >"$work/broker.log" 2>&1 &
broker=$!
for _ in $(seq 50); do
    mosquitto_sub -h 127.0.0.1 -p "$port" -t probe -W 1 -C 1 >/dev/null 2>&1
    [ $? -ne 1 ] && break   # 27: timed out waiting, so the broker answered
    sleep 0.1
done
sub() {  # the retained messages under topic filter $1 (one line each: topic payload)
    # -W: it ends by timing out (status 27), which is no failure here.
    mosquitto_sub -h 127.0.0.1 -p "$port" -t "$1" -v -W 1 --retained-only 2>/dev/null || true
}

# The demo for 6 s: values, health, discovery.
"$rtuscope" demo --seconds 6 --mqtt "mqtt://127.0.0.1:$port/rt" --ha-discovery \
    >"$work/demo.out" 2>"$work/demo.err" || fail "demo --mqtt: $(cat "$work/demo.err")"
sub 'rt/#' >"$work/values"
grep -q '^rt/demo/1/uv_intensity {.*"value":616.8' "$work/values" ||
    fail "no UV intensity of 616.8 in: $(head -40 "$work/values")"
grep '^rt/demo/1/uv_intensity ' "$work/values" | grep -q '"unit":"µW/cm²"' ||
    fail "the UV intensity has not its unit"
grep -q '^rt/demo/3/voltage {.*"value":220.5' "$work/values" ||
    fail "no PDU voltage of 220.5 in: $(head -40 "$work/values")"
grep -q '^rt/demo/3/\$health {' "$work/values" || fail "no health of slave 3"
grep -q '^rt/demo/\$status offline' "$work/values" ||
    fail "the sniffer is not offline after its end: $(grep status "$work/values")"
sub 'homeassistant/#' >"$work/discovery"
grep '/config ' "$work/discovery" | grep '"unit_of_measurement":"V"' |
    grep -q '"device_class":"voltage"' || fail "no voltage sensor discovered: $(head -5 "$work/discovery")"
python3 - "$work/discovery" <<'PY' || fail "a discovery document is not valid JSON"
import json, sys
for line in open(sys.argv[1], encoding="utf-8"):
    topic, _, payload = line.rstrip("\n").partition(" ")
    json.loads(payload)
PY
grep -q 'mqtt: [0-9]* messages published, 0 dropped' "$work/demo.err" ||
    fail "no MQTT summary: $(cat "$work/demo.err")"

# Killed: the broker publishes its last will.
"$rtuscope" demo --mqtt "mqtt://127.0.0.1:$port/killed" >/dev/null 2>&1 &
pid=$!
for _ in $(seq 20); do
    sub 'killed/demo/$status' | grep -q online && break
done
sub 'killed/demo/$status' | grep -q online || fail "the sniffer never came online"
{ kill -KILL "$pid"; wait "$pid"; } 2>/dev/null  # bash reports the killed job on stderr
sleep 1
sub 'killed/demo/$status' | grep -q offline || fail "no last will after SIGKILL"

# A wrong password: one line, and the run goes on; required, it exits 1.
RTUSCOPE_MQTT_USERNAME=field RTUSCOPE_MQTT_PASSWORD=wrong \
    "$rtuscope" demo --seconds 3 --mqtt "mqtt://127.0.0.1:$port/auth" --csv \
    >"$work/auth.out" 2>"$work/auth.err" || fail "a refused password stopped the run"
[ "$(grep -c 'refused the connection' "$work/auth.err")" -eq 1 ] ||
    fail "not one line about the refusal: $(cat "$work/auth.err")"
[ "$(wc -l <"$work/auth.out")" -gt 10 ] || fail "decoding did not go on without MQTT"
RTUSCOPE_MQTT_USERNAME=field RTUSCOPE_MQTT_PASSWORD=wrong \
    "$rtuscope" demo --seconds 10 --mqtt "mqtt://127.0.0.1:$port/auth" --mqtt-required \
    >/dev/null 2>"$work/required.err"
rc=$?
[ $rc -eq 1 ] || fail "--mqtt-required with a refused password: exit $rc, expected 1"
# The right one, from a file.
echo secret >"$work/password"
RTUSCOPE_MQTT_USERNAME=field "$rtuscope" demo --seconds 3 --mqtt "mqtt://127.0.0.1:$port/auth" \
    --mqtt-password-file "$work/password" --mqtt-required >/dev/null 2>"$work/ok.err" ||
    fail "the right password was refused: $(cat "$work/ok.err")"
sub 'auth/demo/3/voltage' | grep -q '"value":220.5' || fail "nothing published with the right password"

# A broker nobody runs: frames come out all the same.
"$rtuscope" demo --seconds 2 --mqtt "mqtt://127.0.0.1:$(free_port)/none" --csv \
    >"$work/none.out" 2>"$work/none.err" || fail "an absent broker stopped the run"
[ "$(wc -l <"$work/none.out")" -gt 10 ] || fail "no frames while the broker is absent"
echo ok
