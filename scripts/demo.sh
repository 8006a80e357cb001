#!/usr/bin/env bash
# `make demo`: the main job on the bundled default (the T-bar), or on DATA=<dataset folder>.
# Every stage's figures go to output/demo/<stage>.log (last line JSON) and into report.md.
set -uo pipefail
BUILD_DIR=${1:-build}
DATA=${2:-}
SOLVER=${SOLVER:-fem}          # dem | fem: the DEM on the T-bar still takes minutes on 2 cores
FEM_ORDER=${FEM_ORDER:-1}      # 1: linear tets (seconds); 2: quadratic (minutes on the T-bar)
TRAIN_SECONDS=${TRAIN_SECONDS:-60}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
OUT="$ROOT/output/demo"
CLI="$ROOT/$BUILD_DIR/bin/demnerf"
SCENARIO=${SCENARIO:-config/scenarios/tbar_twist.yaml}
mkdir -p "$OUT"
REPORT="$OUT/report.md"
printf '# dem_nerf demo\n\n| stage | figures |\n| --- | --- |\n' > "$REPORT"

stage() {  # stage NAME COMMAND...: runs one stage; exit 2 with "not built yet" is said plainly
  local name=$1
  shift
  echo "== $name"
  "$@" --json > "$OUT/$name.log" 2> "$OUT/$name.err"
  local rc=$?
  if [ $rc -eq 0 ]; then
    tail -n 1 "$OUT/$name.log"
    printf '| %s | `%s` |\n' "$name" "$(tail -n 1 "$OUT/$name.log")" >> "$REPORT"
  elif [ $rc -eq 2 ] && grep -q "not built yet" "$OUT/$name.err"; then
    echo "   not built yet: $(cat "$OUT/$name.err")"
    printf '| %s | not built yet |\n' "$name" >> "$REPORT"
  else
    echo "   FAILED ($rc): $(tail -n 3 "$OUT/$name.err")"
    printf '| %s | failed: %s |\n' "$name" "$(tail -n 1 "$OUT/$name.err")" >> "$REPORT"
  fi
  return $rc
}

BUNDLED=false
if [ -z "$DATA" ]; then
  BUNDLED=true
  DATA="$ROOT/output/tbar"
  [ -f "$DATA/transforms_train.json" ] || stage synth "$CLI" synth --scene tbar --out "$DATA"
fi
stage info "$CLI" info --data "$DATA"
[ -f "$OUT/dataset.bag" ] || stage bag "$CLI" bag --data "$DATA" --out "$OUT/dataset.bag"
stage train "$CLI" train --data "$DATA" --out "$OUT/model.nerf" --seconds "$TRAIN_SECONDS"
stage eval "$CLI" eval --model "$OUT/model.nerf" --data "$DATA" --split test
stage extract "$CLI" extract --model "$OUT/model.nerf" --mesh "$OUT/mesh.ply"
# 6 mm: at 1 cm the deformed renderer's tetrahedral embedding of grid particles breaks apart.
stage sample "$CLI" sample --mesh "$OUT/mesh.ply" --method grid --spacing 0.006 --out "$OUT/particles.ply"
SOLVER_OPTIONS=()
[ "$SOLVER" = fem ] && SOLVER_OPTIONS=(--order "$FEM_ORDER")
stage simulate "$CLI" simulate --particles "$OUT/particles.ply" --scenario "$SCENARIO" --solver "$SOLVER" \
  "${SOLVER_OPTIONS[@]}" --out "$OUT/displaced.ply"
stage render "$CLI" render --model "$OUT/model.nerf" --data "$DATA" --split test --out "$OUT/rendered" \
  --result "$OUT/displaced.ply"
if $BUNDLED && [ -f "$OUT/displaced.ply" ]; then
  # Ground truth: the exact T-bar moved by the same displacement, from the same cameras.
  stage truth "$CLI" synth --scene tbar --out "$OUT/truth" --result "$OUT/displaced.ply"
fi
echo "demo outputs are in $OUT (report: $REPORT)"
exit 0
