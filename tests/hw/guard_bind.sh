#!/usr/bin/env bash
# Issue 23 item 2: the guard's DDS receive sockets listen only on the interface the Cyclone
# configuration selects. Cyclone 0.10 binds them to 0.0.0.0; the guard binds them to lo (the one
# interface of tests/hw/cyclonedds-loopback.xml) with SO_BINDTODEVICE. Checked from outside:
# - `ss` shows each of the guard's wildcard UDP sockets bound to %lo;
# - a datagram to one of the guard's ports at this host's non-loopback address is refused by the
#   kernel (ICMP port unreachable -> ECONNREFUSED at the sender), while the same datagram to
#   127.0.0.1 reaches a socket (no refusal): the probe tells a listening port from a bound one.
# A flood of malformed datagrams to those ports from this host puts one line of Cyclone's warning
# in the guard's log per 10 s, not one per datagram. Then the same guard with a configuration
# that selects two interfaces warns that its sockets stay on every interface ("fallback (dds
# binding)").
# Usage: guard_bind.sh ROSGUARD SOURCE_DIR
set -euo pipefail
rosguard=$1
src=$2
command -v ss >/dev/null || { echo "SKIPPED: ss (iproute2) is not installed"; exit 0; }
# shellcheck source=guard_common.sh
source "$src/tests/hw/guard_common.sh"
# (|| true: an empty log, or head closing the pipe, must not end the script before it says why)
fail() { echo "--- guard log"; grep -v -- "-> THR\|-> ON" "$tmp/log" | head -40 || true; echo "FAIL: $*"; exit 1; }
address=$(ip -4 -o addr show scope global 2>/dev/null | awk '{print $4}' | cut -d/ -f1 | head -1)
[[ -n $address ]] || { echo "SKIPPED: this host has no IPv4 address outside lo to probe from"; exit 0; }

guard_start bind
grep -q "bound to lo" "$tmp/log" || fail "the guard does not say its receive sockets are bound to lo"
! grep -q "fallback (dds binding)" "$tmp/log" || fail "the guard reports a binding fallback"
ports=$(sed -n 's/.*UDP port(s) \([0-9, ]*\)).*/\1/p' "$tmp/log" | head -1 | tr -d ' ' | tr ',' ' ')
[[ -n $ports ]] || fail "the guard's log names no receive port"
echo "guard $guard_pid: receive ports $ports; probing from $address"

# Every wildcard UDP socket of the guard is bound to lo.
ss -uanp | grep "pid=$guard_pid," >"$tmp/ss" || fail "ss lists no UDP socket of the guard"
cat "$tmp/ss"
awk '$4 ~ /^(0\.0\.0\.0|\[::\]|\*)(%[^:]*)?:/ && $4 !~ /%lo:/ { bad = 1 } END { exit bad }' "$tmp/ss" ||
  fail "a wildcard UDP socket of the guard is not bound to lo"

# probe ADDRESS PORT: "refused" when the kernel answers port unreachable, else "delivered".
probe() {
  /usr/bin/python3 - "$1" "$2" <<'EOF'
import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.connect((sys.argv[1], int(sys.argv[2])))
s.settimeout(0.2)
verdict = "delivered"
for _ in range(3):
    try:
        s.send(b"rosguard bind probe")
        s.recv(64)
    except ConnectionRefusedError:
        verdict = "refused"
        break
    except socket.timeout:
        pass
print(verdict)
EOF
}
for port in $ports; do
  outside=$(probe "$address" "$port")
  inside=$(probe 127.0.0.1 "$port")
  echo "port $port: from $address $outside, from 127.0.0.1 $inside"
  [[ $outside == refused ]] || fail "a datagram to $address:$port reached the guard"
  [[ $inside == delivered ]] || fail "a datagram to 127.0.0.1:$port was refused: the probe cannot tell"
done
# A flood of malformed RTPS datagrams from this host: Cyclone warns about each one (~270 bytes);
# the guard's log takes at most one such line per 10 s, and counts the rest at stop.
first_port=${ports%% *}
bytes_before=$(wc -c <"$tmp/log")
/usr/bin/python3 - "$first_port" <<'EOF'
import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
for i in range(5000):
    s.sendto(b"RTPS\x02\x01" + bytes(range(40)), ("127.0.0.1", int(sys.argv[1])))
EOF
sleep 0.5
grown=$(($(wc -c <"$tmp/log") - bytes_before))
warned=$(grep -c "cyclone: malformed packet" "$tmp/log" || true)
echo "5000 malformed datagrams: the log grew $grown bytes, $warned line(s) of Cyclone's warning"
[[ $warned -ge 1 && $warned -le 2 ]] || fail "$warned lines of Cyclone's malformed-packet warning, expected 1 or 2"
((grown < 4096)) || fail "the log grew $grown bytes under the flood"
kill -TERM "$guard_pid"
rc=0
wait "$guard_pid" || rc=$?
guard_pid=""
[[ $rc -eq 0 ]] || fail "guard exited $rc"
grep "cyclone: .* repeat(s) not logged" "$tmp/log" || fail "the guard does not count Cyclone's repeats at stop"

# Two interfaces selected: a socket binds to one device, so the guard warns instead.
iface=$(ip -4 -o addr show scope global | awk '{print $2}' | head -1)
sed "s|<NetworkInterface name=\"lo\"/>|<NetworkInterface name=\"lo\"/><NetworkInterface name=\"$iface\"/>|" \
  "$src/tests/hw/cyclonedds-loopback.xml" >"$tmp/two.xml"
# The first guard's log goes first: the shell truncates it only once the child runs, so the wait
# below could find the first guard's lines (seen: 1 of 14 busy passes of the hw suite).
rm -f "$tmp/log"
CYCLONEDDS_URI="file://$tmp/two.xml" "$rosguard" guard "$tmp/guard.json" 2>"$tmp/log" &
guard_pid=$!
for _ in $(seq 200); do grep -qs "regulating be (CPU 1)" "$tmp/log" && break; sleep 0.1; done
grep -q "regulating be (CPU 1)" "$tmp/log" || fail "the guard with two interfaces did not start"
grep "fallback (dds binding)" "$tmp/log" || fail "no binding fallback with two interfaces"
grep -q "2 interfaces" "$tmp/log" || fail "the fallback does not say two interfaces were selected"
kill -TERM "$guard_pid"
rc=0
wait "$guard_pid" || rc=$?
guard_pid=""
[[ $rc -eq 0 ]] || fail "the guard with two interfaces exited $rc"
echo "OK: receive sockets bound to lo, refused from $address; a visible fallback with two interfaces"
