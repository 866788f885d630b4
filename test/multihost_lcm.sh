#!/bin/sh
# LCM with ?ttl=1 crosses test hosts joined by a bridge, and stops when a host's link is cut;
# depowder-status tells a host whose clock runs ahead (its wall clock set 3 s ahead by
# CLOCK_STEP_LIB, test/clock_step.cpp preloaded), hosts whose cell files differ (a part's initial
# pose 1 mm apart) and two of one cell process.
set -eu
BIN=$1
CLOCK_STEP_LIB=$2
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
# The clocks: the same machine's (under 50 ms apart), then host 3's wall clock set 3 s ahead.
clock_ms() {  # prints the clock difference depowder-status reports for depowder-estop, sent by "$@"
  "$H" exec $T 1 "$BIN/depowder-status" --wait-for depowder-estop --timeout 5 > clock.out & p=$!
  sleep 0.5
  "$H" exec $T 3 "$@" "$BIN/depowder-estop" stop --reason clock > /dev/null
  wait $p && sed -n 's/.*its clock \([-+0-9.]*\) ms.*/\1/p' clock.out
}
same=$(clock_ms env) || same=""
echo 3 > ahead
# (An AddressSanitizer build, scripts/sanitize, wants its runtime ahead of any preload.)
ahead=$(clock_ms env LD_PRELOAD="$CLOCK_STEP_LIB" DEPOWDER_CLOCK_STEP_FILE="$PWD/ahead" \
  ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}verify_asan_link_order=0") || ahead=""
echo "clock difference: same clock ${same:-?} ms, host 3 set 3 s ahead ${ahead:-?} ms"
if awk -v a="$same" -v b="$ahead" 'BEGIN { exit !(a != "" && b != "" && a > -50 && a < 50 && b > 2950 && b < 3050) }'; then
  pass=$((pass+1)); echo "ok: clock differences"
else
  fail=$((fail+1)); echo "FAILED: clock differences"
fi
# The cell files: depowder-progress on hosts 1 and 2, with the same cell file and then with one
# whose part starts 1 mm higher; depowder-status on host 3.
SRC=$(cd "$(dirname "$0")/.." && pwd)
sed "s|mesh: parts/|mesh: $SRC/config/parts/|" "$SRC/config/cell.yaml" > same.yaml
sed 's/xyz: \[0.0, 0.0, 0.06\]/xyz: [0.0, 0.0, 0.061]/' same.yaml > other.yaml
cmp -s same.yaml other.yaml && { echo "FAILED: other.yaml is not another cell"; exit 1; }
cells_differ() {  # prints what depowder-status says of the cell files of hosts 1 and 2
  "$H" exec $T 1 "$BIN/depowder-progress" --cell same.yaml > progress1.log 2>&1 & a=$!
  "$H" exec $T 2 "$BIN/depowder-progress" --cell "$1" > progress2.log 2>&1 & b=$!
  sleep 1
  "$H" exec $T 3 "$BIN/depowder-status" --once --timeout 2 > cells.out
  kill $a $b; wait $a $b 2> /dev/null || true
  grep -c "^depowder-progress@" cells.out | grep -q '^2$' || echo "not both heard"
  grep "cell files differ" cells.out || true
}
same=$(cells_differ same.yaml)
# Two progress estimators on one bus: one cell runs one of each process.
if grep -q "^more than one depowder-progress: depowder-progress@" cells.out; then
  pass=$((pass+1)); echo "ok: two of one process told"
else
  fail=$((fail+1)); echo "FAILED: two of one process told"; cat cells.out
fi
other=$(cells_differ other.yaml)
echo "same cell files: '${same}'; one part 1 mm apart: '${other}'"
if [ -z "$same" ] && echo "$other" | grep -q "^cell files differ" && ! echo "$other" | grep -q "not both"; then
  pass=$((pass+1)); echo "ok: cell files told apart"
else
  fail=$((fail+1)); echo "FAILED: cell files told apart"
fi
"$H" cut $T 3
"$H" exec $T 1 "$BIN/depowder-status" --wait-for depowder-estop --timeout 2 & p=$!
sleep 0.5
"$H" exec $T 3 "$BIN/depowder-estop" stop --reason cut
if wait $p; then fail=$((fail+1)); echo "FAILED: heard host 3 through a cut link"; else pass=$((pass+1)); echo "ok: cut link is silent"; fi
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
