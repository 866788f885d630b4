#!/bin/sh
# Two processes exchange typed LCM messages over udpm inside a private namespace:
# depowder-status waits for depowder-estop's heartbeat.
set -eu
BIN=$1
"$BIN/depowder-status" --wait-for depowder-estop --timeout 10 > status.out 2>&1 &
listener=$!
sleep 0.5
"$BIN/depowder-estop" stop --reason "two-process test"
wait $listener
grep -q "heard depowder-estop" status.out
echo "1 passed, 0 failed"
