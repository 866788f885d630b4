#!/bin/sh
# LCM with ?ttl=1 crosses test hosts joined by a bridge, and stops when a host's link is cut.
set -eu
BIN=$1
H=$(dirname "$0")/netns-hosts
[ "$(id -u)" -eq 0 ] || { echo "SKIPPED: needs root for ip netns"; echo "0 passed, 0 failed, 1 skipped"; exit 0; }
T=mhl$$
"$H" up $T 3
trap '"$H" down $T' EXIT
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=1"
pass=0; fail=0
"$H" exec $T 1 "$BIN/depowder-status" --wait-for depowder-estop --timeout 5 & p=$!
sleep 0.5
"$H" exec $T 3 "$BIN/depowder-estop" stop --reason multihost
if wait $p; then pass=$((pass+1)); echo "ok: host 3 -> host 1"; else fail=$((fail+1)); echo "FAILED: host 3 -> host 1"; fi
"$H" cut $T 3
"$H" exec $T 1 "$BIN/depowder-status" --wait-for depowder-estop --timeout 2 & p=$!
sleep 0.5
"$H" exec $T 3 "$BIN/depowder-estop" stop --reason cut
if wait $p; then fail=$((fail+1)); echo "FAILED: heard host 3 through a cut link"; else pass=$((pass+1)); echo "ok: cut link is silent"; fi
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
