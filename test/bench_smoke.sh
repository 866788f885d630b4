#!/bin/sh
# Every benchmark, once, at its smallest size: it must finish and print its figures. No figure
# is held to a goal here (speed and latency goals live in the benchmarks, whose figures need a
# quiet machine and full-size runs); this catches a benchmark that a change broke, which no
# other test runs. The two that talk LCM between processes over udpm (the driver's safety timing,
# the camera's latency) run in a private network namespace (test/netns-run), as every such test
# does. bench_camera_latency, on a run this short, misses its own latency goal (its exit status
# then is 1), so it is checked only for the line that reports on the goals after a full run.
#   test/bench_smoke.sh BIN_DIR NETNS_RUN
set -u
bin=$1; netns_run=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
failed=""

# check NAME STATUS_WANTED PATTERN COMMAND...: COMMAND exits STATUS_WANTED ("any": any status
# but a signal's) and prints a line matching PATTERN.
check() {
  name=$1; want=$2; pattern=$3; shift 3
  start=$(date +%s)
  "$@" > "$out/$name.log" 2>&1
  status=$?
  took=$(( $(date +%s) - start ))
  why=""
  if [ "$status" -eq 77 ] && grep -q "SKIPPED" "$out/$name.log"; then
    echo "skip $name: $(grep SKIPPED "$out/$name.log" | head -n 1)"
    return
  fi
  if [ "$want" = any ]; then
    [ "$status" -lt 128 ] || why="killed by signal $((status - 128))"
  elif [ "$status" -ne "$want" ]; then
    why="exit status $status"
  fi
  [ -n "$why" ] || grep -q -- "$pattern" "$out/$name.log" || why="no line matching '$pattern'"
  if [ -n "$why" ]; then
    echo "FAIL $name ($took s): $why; its last lines:"
    tail -n 15 "$out/$name.log" | sed 's/^/    /'
    failed="$failed $name"
  else
    echo "ok   $name ($took s): $(grep -- "$pattern" "$out/$name.log" | head -n 1 | cut -c1-110)"
  fi
}

if [ -x "$bin/depowder-bench" ]; then  # built only with PCL
  check tracker 0 "CU-ICP vs PCL, median" "$bin/depowder-bench" --frames 2 --parts cube --visibilities 0.7 \
    --methods cu,pcl --json "$out/tracker.json"
  for key in cu_icp_ms_median pcl_icp_ms_median speedup cu_icp_rot_err_deg pcl_icp_trans_err_cm frames; do
    grep -q "\"$key\"" "$out/tracker.json" 2>/dev/null || { echo "FAIL tracker: no \"$key\" in its JSON"; failed="$failed tracker-json"; }
  done
fi
check planner 0 "goal: zero waypoints in collision" "$bin/depowder-planner-bench" --poses 1
check progress 0 "topple_frames" "$bin/depowder-progress-bench" --yaws 1 --repeats 1
check progress-sim 0 "^ALL " "$bin/depowder-progress-sim-bench" --yaws 1
check sim 0 "world step, thread CPU time" "$bin/depowder-sim-bench" --frames 3
check sim-physics 0 "real-time factor" "$bin/depowder-sim-physics-bench" --duration 1
check perception 0 "per merged frame, CPU" "$bin/bench_perception" --frames 3
check driver-jitter 0 "within 8 +- 1 ms" "$bin/depowder-driver-bench-jitter" --seconds 3 --no-realtime
check driver-safety 0 "arm at rest (emulator)" "$netns_run" "$bin/depowder-driver-bench-safety" --reps 1
check camera-latency any "goals (no POINTS lost" "$netns_run" "$bin/bench_camera_latency" --seconds 2

[ -z "$failed" ] || { echo "benchmarks that failed:$failed"; exit 1; }
echo "all benchmarks ran and printed their figures"
