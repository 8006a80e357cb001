#!/usr/bin/env bash
# `make demo`: the main job on the bundled default (the T-bar), or on DATA=<dataset folder>.
# Runs every stage that is built and says plainly which are not built yet.
set -uo pipefail
BUILD_DIR=${1:-build}
DATA=${2:-}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
OUT="$ROOT/output/demo"
CLI="$ROOT/$BUILD_DIR/bin/demnerf"
mkdir -p "$OUT"

stage() {  # stage NAME COMMAND...: runs one stage; exit 2 means "not built yet"
  local name=$1
  shift
  echo "== $name"
  "$@" --json > "$OUT/$name.log" 2> "$OUT/$name.err"
  local rc=$?
  if [ $rc -eq 0 ]; then
    tail -n 1 "$OUT/$name.log"
  elif [ $rc -eq 2 ] && grep -q "not built yet" "$OUT/$name.err"; then
    echo "   not built yet: $(cat "$OUT/$name.err")"
  else
    echo "   FAILED ($rc): $(tail -n 3 "$OUT/$name.err")"
  fi
  return $rc
}

if [ -z "$DATA" ]; then
  DATA="$ROOT/output/tbar"
  if [ ! -f "$DATA/transforms_train.json" ]; then
    stage synth "$CLI" synth --scene tbar --out "$DATA" || true
  fi
fi
if [ -d "$DATA" ]; then
  stage info "$CLI" info --data "$DATA"
  [ -f "$OUT/tbar.bag" ] || stage bag "$CLI" bag --data "$DATA" --out "$OUT/tbar.bag"
fi
stage train "$CLI" train --data "$DATA" --out "$OUT/model.nerf" --seconds 60
stage extract "$CLI" extract --model "$OUT/model.nerf" --mesh "$OUT/mesh.ply"
MESH="$OUT/mesh.ply"
if [ ! -f "$MESH" ] && [ -f "$DATA/mesh.ply" ]; then
  echo "   (no mesh from the NeRF: sampling the dataset's exact mesh instead)"
  MESH="$DATA/mesh.ply"
fi
stage sample "$CLI" sample --mesh "$MESH" --method poisson --spacing 0.01 --out "$OUT/particles.ply"
stage simulate "$CLI" simulate --particles "$OUT/particles.ply" --scenario config/scenarios/tbar_twist.yaml \
  --solver dem --out "$OUT/displaced.ply"
stage render "$CLI" render --model "$OUT/model.nerf" --data "$DATA" --split test --out "$OUT/rendered" \
  --result "$OUT/displaced.ply"
echo "demo outputs are in $OUT"
exit 0
