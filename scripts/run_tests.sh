#!/usr/bin/env bash
# Runs every gtest (through ctest) and every rostest (test/*.test), then tallies the JUnit XML
# they write. The last line is "N passed, N failed[, N skipped]"; the exit code is non-zero on
# any failure.
set -uo pipefail
BUILD_DIR=${1:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
# The build folder as an absolute path (relative ones are taken from the repository root).
BUILD_DIR=$(cd "$ROOT" && realpath -m "$BUILD_DIR")
cd "$ROOT"
RESULTS="$BUILD_DIR/test_results"
rm -rf "$RESULTS" && mkdir -p "$RESULTS/rostest"
# ROS's Python tools (rostest, hztest) need Debian's python3, which a pyenv or venv may shadow.
export PATH="/usr/bin:$PATH"
export ROS_HOME="$BUILD_DIR/ros_home"
rm -rf "$ROS_HOME" && mkdir -p "$ROS_HOME"  # no model autosaved by an earlier run is resumed
export ROS_TEST_RESULTS_DIR="$RESULTS/rostest"
export ROSCONSOLE_FORMAT='[${severity}] [${node}]: ${message}'
# The ROS environment scripts read unset variables, so they are sourced without -u.
set +u
# shellcheck disable=SC1091
source "$BUILD_DIR/devel/setup.bash"
set -u

status=0
skipped_suites=0
# DEMNERF_TEST_SET=nodes (make test SANITIZE=address): the node tests only.
TEST_SET=${DEMNERF_TEST_SET:-all}
echo "== gtests"
if [ "$TEST_SET" = nodes ]; then
  (cd "$BUILD_DIR" && ctest --output-on-failure --timeout 600 -R '^test_ros_conversions$') || status=1
else
  (cd "$BUILD_DIR" && ctest --output-on-failure --timeout 600) || status=1
fi

echo "== rostests"
# A small synthetic scene for the tests that train (made by our own renderer, so no ../shared).
TEST_DATA="$BUILD_DIR/test_data"
if [ ! -f "$TEST_DATA/cuboid/transforms_train.json" ]; then
  "$BUILD_DIR/bin/demnerf" synth --scene cuboid --views 24 --test-views 4 --size 64 --out "$TEST_DATA/cuboid" > /dev/null \
    || { echo "could not generate the test scene"; status=1; }
fi
launch_files=(test/*.test)
[ "$TEST_SET" = nodes ] && launch_files=(test/dem_node_bad_input.test test/nodes_advertise.test test/nodes_fuzz.test)
for launch_file in "${launch_files[@]}"; do
  needs_shared=$(grep -l 'shared/data' "$launch_file" || true)
  if [ -n "$needs_shared" ] && [ ! -d "$ROOT/../shared/data" ]; then
    echo "SKIPPED $launch_file: it replays ../shared/data, which is absent beside this clone"
    skipped_suites=$((skipped_suites + 1))
    continue
  fi
  echo "-- rostest $launch_file"
  extra_args=()
  grep -q 'name="test_data"' "$launch_file" && extra_args+=("test_data:=$TEST_DATA")
  if ! rostest "$launch_file" "${extra_args[@]}" > "$RESULTS/rostest/$(basename "$launch_file" .test).log" 2>&1; then
    status=1
    echo "FAILED $launch_file; its output:"
    tail -40 "$RESULTS/rostest/$(basename "$launch_file" .test).log"
  fi
done

summary=$(/usr/bin/python3 scripts/tally_results.py "$RESULTS" "$skipped_suites") || status=1
echo "$summary" | head -n -1
[ "$status" -eq 0 ] || echo "some test binary or rostest failed (see above)"
echo "$summary" | tail -n 1
exit $status
