#!/bin/sh
# The README's first command as a user runs it: scripts/demo depowders the default cell end to
# end (config/deploy/demo.yaml, the cell in a private network namespace; as root, or it skips).
# Checked from the run's summary.json: the monitor saw every part done, no nozzle-part contact,
# no driver fault, safety stop or ESTOP, and each part's final pose and eta within the bounds
# below of the simulator's truth (the README's measured row: 0.60 deg / 0.09 cm, eta 90.4 %
# against 90.0 %). The run directory (runs/...) is removed when the test passes and kept, with
# its path printed, when it fails. scripts/demo builds into SOURCE_DIR/build, so the test runs
# only from that build directory (it skips from any other: it would start a second build).
#   test/demo.sh SOURCE_DIR BUILD_DIR
set -u
cd "$1"
[ "$(cd "$2" && pwd -P)" = "$(pwd -P)/build" ] || { echo "SKIPPED: scripts/demo builds into $1/build, not $2"; exit 77; }
[ "$(id -u)" -eq 0 ] || { echo "SKIPPED: scripts/demo runs the cell in a private namespace as root only"; exit 77; }
scripts/demo > demo.out 2>&1
status=$?
run=$(sed -n 's/^depowder demo: .* run dir \(runs\/[^ ]*\)$/\1/p' demo.out | head -n 1)
mv demo.out "${run:-.}/demo.out" 2>/dev/null || true
out="${run:-.}/demo.out"
fail() {
  echo "FAILED: $1"
  tail -n 25 "$out"
  echo "(the run is kept in ${run:-nowhere})"
  exit 1
}
[ -n "$run" ] || fail "scripts/demo did not say where its run went (exit status $status)"
[ "$status" -eq 0 ] || fail "scripts/demo exited with status $status"
summary="$run/summary.json"
[ -f "$summary" ] || fail "no $summary"
grep -q '"done": true' "$summary" || fail "the monitor did not see every part done"
for key in contacts driver_faults driver_safety_stops driver_estops; do
  grep -q "\"$key\": 0," "$summary" || fail "$key is not 0: $(grep "\"$key\"" "$summary")"
done
# Each part against the truth: 5 deg (a third of the paper's 15 deg success criterion), 0.5 cm
# and 0.05 of eta, several times what the runs in the README measured.
bad=$(awk -F'[:,}]' '/"part":/ {
    for (i = 1; i < NF; i++) { k = $i; gsub(/[ "{]/, "", k); v[k] = $(i + 1) }
    if (v["rot_err_deg"] + 0 > 5 || v["trans_err_cm"] + 0 > 0.5 || (v["eta"] - v["true_eta"]) ^ 2 > 0.05 ^ 2)
      print $0
  }' "$summary")
[ -z "$bad" ] || fail "a part ended off the truth (limits 5 deg, 0.5 cm, eta 0.05): $bad"
sed -n '/"parts"/,/\]/p;/elapsed_s/p;/latency_ms_p99/p;/points_lost/p' "$summary"
rm -rf "$run"
echo "scripts/demo: the default cell depowdered, every check passed"
