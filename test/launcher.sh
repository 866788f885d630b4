#!/bin/sh
# depowder-launch: order, output capture, restart with back-off, give-up, ends_run,
# LCM status, and a clean stop on SIGTERM, or the launcher's death, that leaves no process behind.
set -eu
BIN=$1
rm -rf run1 run2 run3
NAP=300.$$  # the sleepers' argument: no other process on the machine has it
pass=0
fail=0
check() {  # check "what" command...
  what=$1; shift
  if "$@"; then pass=$((pass + 1)); echo "ok: $what"; else fail=$((fail + 1)); echo "FAILED: $what"; fi
}

cat > deploy.yaml <<'YAML'
hosts:
  - name: t
    processes:
      - {name: crasher, command: sh, args: [-c, "echo crash-${TAG}; exit 3"], restart: on-failure, max_restarts: 2}
      - {name: sleeper, command: sleep, args: ["${NAP}"], restart: never}
      - name: watcher  # lets the crasher run out its restarts (0.5 + 1 s back-off) first
        command: sh
        args: [-c, 'sleep 3 && exec "$0" --wait-for depowder-launch --timeout 20', "${BIN_DIR}/depowder-status"]
        ends_run: true
        start_delay_s: 0
YAML
set +e
"$BIN/depowder-launch" deploy.yaml --run-dir run1 --set TAG=x --set NAP=$NAP > launch1.out 2>&1
code=$?
set -e
cat launch1.out
check "ends_run process's exit code (heard the launcher's heartbeat over LCM)" [ "$code" -eq 0 ]
check "crasher ran 1 + 2 restarts" [ "$(grep -c '^crash-x$' run1/crasher.log)" -eq 3 ]
check "crasher gave up" grep -q "gave up after 2 restarts" run1/crasher.log
check "output is prefixed" grep -q "^\[crasher\] crash-x" launch1.out
check "sleeper was stopped" sh -c "! pgrep -f '^sleep $NAP\$' > /dev/null"

cat > deploy2.yaml <<'YAML'
hosts:
  - name: t
    processes:
      - {name: sleeper, command: sleep, args: ["${NAP}"]}
YAML
"$BIN/depowder-launch" deploy2.yaml --run-dir run2 --set NAP=$NAP > launch2.out 2>&1 &
launcher=$!
sleep 1
kill -TERM $launcher
start=$(date +%s)
wait $launcher || true
check "SIGTERM stops within 6 s" [ $(( $(date +%s) - start )) -le 6 ]
check "no sleeper left after SIGTERM" sh -c "! pgrep -f '^sleep $NAP\$' > /dev/null"

"$BIN/depowder-launch" deploy2.yaml --run-dir run3 --set NAP=$NAP > launch3.out 2>&1 &
launcher=$!
sleep 1
check "sleeper running under the launcher" sh -c "pgrep -f '^sleep $NAP\$' > /dev/null"
kill -KILL $launcher
wait $launcher || true
gone=no
for _ in 1 2 3 4 5 6 7 8 9 10; do
  if ! pgrep -f "^sleep $NAP\$" > /dev/null; then gone=yes; break; fi
  sleep 0.2
done
check "no sleeper left after the launcher is killed (SIGKILL)" [ "$gone" = yes ]

cat > bad.yaml <<'YAML'
hosts:
  - name: t
    processes:
      - {name: a, command: sleep, restart: sometimes}
YAML
set +e
"$BIN/depowder-launch" bad.yaml > bad.out 2>&1
code=$?
set -e
check "bad deployment is refused with its key named" sh -c "[ $code -eq 2 ] && grep -q \"hosts\[0\].processes\[0\].restart\" bad.out"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
