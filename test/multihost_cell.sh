#!/bin/sh
# The cell across three test hosts joined by a bridge (config/deploy/three_hosts.yaml):
# camera host (sim with its b-CAP controller emulator, camera proxy), compute host
# (tracker, progress, planner, monitor), robot host (driver, reaching the emulator
# across hosts over b-CAP). LCM with ttl=1. Passes when the monitor reports every part
# done with no nozzle-part contact.
set -eu
BIN=$1
SRC=$2
H=$SRC/test/netns-hosts
[ "$(id -u)" -eq 0 ] || { echo "SKIPPED: needs root for ip netns"; exit 77; }
T=mhc$$
"$H" up $T 3
cleanup() {
  for p in ${camera_pid:-} ${robot_pid:-}; do kill -TERM "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  "$H" down $T
}
trap cleanup EXIT
camera_ip=$("$H" ip $T 1)
# The default cell, with the controller on the camera host and its emulator listening on the LAN.
sed -e "s#^    host: 127.0.0.1 .*#    host: $camera_ip#" \
    -e "s#^  emulator_bind: 127.0.0.1.*#  emulator_bind: 0.0.0.0#" \
    -e "s#mesh: parts/#mesh: $SRC/config/parts/#" "$SRC/config/cell.yaml" > cell.yaml
grep -q "host: $camera_ip" cell.yaml && grep -q "emulator_bind: 0.0.0.0" cell.yaml
rm -rf run1 run2 run3
launch() {  # launch HOST_INDEX HOST_NAME RUN_DIR [more args]
  i=$1; name=$2; dir=$3; shift 3
  "$H" exec $T "$i" "$BIN/depowder-launch" "$SRC/config/deploy/three_hosts.yaml" --host "$name" \
    --run-dir "$dir" --set CELL="$PWD/cell.yaml" "$@"
}
launch 1 camera run1 > camera.out 2>&1 & camera_pid=$!
launch 3 robot run3 > robot.out 2>&1 & robot_pid=$!
set +e
launch 2 compute run2 --set TIMEOUT=500 > compute.out 2>&1
code=$?
set -e
grep -A20 "run summary" compute.out || tail -20 compute.out
echo "driver on the robot host:"; grep "depowder-driver:" robot.out | head -5
if [ "$code" -eq 0 ] && grep -q '"done": true' run2/summary.json && grep -q '"contacts": 0' run2/summary.json; then
  echo "1 passed, 0 failed"
else
  echo "0 passed, 1 failed"
  exit 1
fi
