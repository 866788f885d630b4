#!/bin/sh
# The project's lcm-spy launcher starts under Xvfb with Java 17 and finds every
# depowder type (one per lcmtypes/*.lcm).
set -eu
BIN=$1
SRC=$2
expected=$(ls "$SRC"/lcmtypes/*.lcm | wc -l)
timeout 30 xvfb-run -a sh -c "timeout 12 '$BIN/depowder-spy' > spy.out 2>&1 || true"
cat spy.out
found=$(sed -n 's/^Found \([0-9][0-9]*\) LCM types.*/\1/p' spy.out | head -1)
if [ "$found" = "$expected" ]; then
  echo "lcm-spy found $found of $expected depowder types"
  echo "1 passed, 0 failed"
else
  echo "lcm-spy found '${found}' types, expected $expected"
  echo "0 passed, 1 failed"
  exit 1
fi
