#!/bin/sh
# The project's lcm-spy launcher, started by depowder-launch beside a publishing process,
# runs under Xvfb with Java 17 and finds every depowder type (one per lcmtypes/*.lcm and
# lcmtypes/legacy/*.lcm).
set -eu
BIN=$1
SRC=$2
expected=$(ls "$SRC"/lcmtypes/*.lcm "$SRC"/lcmtypes/legacy/*.lcm | wc -l)
cat > spy.yaml <<'YAML'
hosts:
  - name: t
    processes:
      - {name: spy, command: depowder-spy, restart: never}
      - {name: status, command: depowder-status, args: [--timeout, "12", --once], restart: never}
      - {name: timer, command: sleep, args: ["12"], restart: never, ends_run: true}
YAML
rm -rf run
timeout 60 xvfb-run -a "$BIN/depowder-launch" spy.yaml --run-dir run > launch.out 2>&1 || true
cat run/spy.log
found=$(sed -n 's/^Found \([0-9][0-9]*\) LCM types.*/\1/p' run/spy.log | head -1)
if [ "$found" = "$expected" ]; then
  echo "lcm-spy (under depowder-launch) found $found of $expected depowder types"
  echo "1 passed, 0 failed"
else
  echo "lcm-spy found '${found}' types, expected $expected"
  echo "0 passed, 1 failed"
  exit 1
fi
