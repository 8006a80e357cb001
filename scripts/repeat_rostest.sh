#!/usr/bin/env bash
# Runs one rostest N times the way scripts/run_tests.sh runs it, optionally beside busy loops,
# and counts the failures: a flaky check fails once in many runs, and CPU load widens its window.
#   bash scripts/repeat_rostest.sh BUILD_DIR TEST_FILE N [BUSY_LOOPS]
# GTEST_FILTER=Suite.Name narrows the check to one gtest. Each run's output is kept under
# BUILD_DIR/repeat_rostest/<test>/run_<i>.log; the last line is "F failures / N runs".
set -uo pipefail
if [ $# -lt 3 ]; then
  echo "usage: $0 BUILD_DIR TEST_FILE N [BUSY_LOOPS]" >&2
  exit 2
fi
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD_DIR=$(realpath -m "$1")
TEST_FILE=$(realpath -m "$2")
RUNS=$3
BUSY_LOOPS=${4:-0}
NAME=$(basename "$TEST_FILE" .test)
OUT="$BUILD_DIR/repeat_rostest/$NAME"
rm -rf "$OUT" && mkdir -p "$OUT"
# The environment of scripts/run_tests.sh: Debian's python3, a fresh ROS_HOME, short log lines.
export PATH="/usr/bin:$PATH"
export ROS_HOME="$OUT/ros_home"
mkdir -p "$ROS_HOME"
export ROSCONSOLE_FORMAT='[${severity}] [${node}]: ${message}'
set +u
# shellcheck disable=SC1091
source "$BUILD_DIR/devel/setup.bash"
set -u

loops=()
for _ in $(seq 1 "$BUSY_LOOPS"); do
  bash -c 'while :; do :; done' &
  loops+=($!)
done
trap 'for pid in "${loops[@]}"; do kill "$pid" 2>/dev/null; done' EXIT

failures=0
cd "$ROOT"
for i in $(seq 1 "$RUNS"); do
  export ROS_TEST_RESULTS_DIR="$OUT/results_$i"
  if rostest "$TEST_FILE" > "$OUT/run_$i.log" 2>&1; then result=ok; else result=FAILED; failures=$((failures + 1)); fi
  echo "run $i: $result"
done
echo "$failures failures / $RUNS runs"
