#!/usr/bin/env bash
# `make bench`: runs every benchmark built under <build>/bin/bench and prints their figures.
set -uo pipefail
BUILD_DIR=${1:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
shopt -s nullglob
benches=("$ROOT/$BUILD_DIR"/bin/bench/*)
if [ ${#benches[@]} -eq 0 ]; then
  echo "no benchmarks are built yet"
  exit 0
fi
status=0
for bench in "${benches[@]}"; do
  echo "== $(basename "$bench")"
  "$bench" || status=1
done
exit $status
