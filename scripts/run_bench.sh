#!/usr/bin/env bash
# `make bench`: the benchmarks under bench/, each printing its figures (timings are wall time on
# this machine; run on a quiet machine and quote the median of the runs they print).
# BENCH="name ..." runs a subset.
set -uo pipefail
BUILD_DIR=${1:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
# The build folder as an absolute path (relative ones are taken from the repository root).
BUILD_DIR=$(cd "$ROOT" && realpath -m "$BUILD_DIR")
cd "$ROOT"
BIN="$BUILD_DIR/bin/bench"
OUT="$ROOT/output/bench"
mkdir -p "$OUT"
TBAR="$ROOT/output/tbar"
[ -f "$TBAR/transforms_train.json" ] || "$BUILD_DIR/bin/demnerf" synth --scene tbar --out "$TBAR" > /dev/null

declare -A COMMANDS=(
  [render_synth_bench]="--repeat 3 --out $OUT/synth"
  [geometry_sampling_bench]=""
  [nerf_kernels]=""
  # PSNR against training time as CPU seconds of the process (2 x the wall seconds of an idle
  # 2-core machine; a shared machine inflates wall time far more), CSV + PNG. T-bar: issue 16's
  # >= 33 dB in 30 s; fox: >= 28 dB in 60 s, >= 30 dB in 300 s.
  [nerf_train]="--data $TBAR --cpu-seconds 120 --eval-every 20 --csv $OUT/nerf_tbar.csv --plot $OUT/nerf_tbar.png"
  [nerf_train_fox]="--data $ROOT/../shared/data/fox --downscale 4 --config $ROOT/packages/nerf/config/nerf_fox.yaml --cpu-seconds 600 --eval-every 120 --csv $OUT/nerf_fox.csv --plot $OUT/nerf_fox.png"
  [nerf_train_fox_views]="--data $ROOT/../shared/data/fox --downscale 4 --config $ROOT/packages/nerf/config/nerf_fox_views.yaml --cpu-seconds 600 --eval-every 120 --csv $OUT/nerf_fox_views.csv --plot $OUT/nerf_fox_views.png"
  [geometry_tbar_extraction]="--work $OUT/extraction --resolution 192 --repeat 3"
  [mechanics_cook]=""
  [mechanics_dem]="case=uniaxial seeds=3 width=16 depth=2 iters=1000 lr=1e-2"
  [mechanics_dem_tbar_grid]="case=tbar iters=0 grid=0.015 seeds=3"
  [mechanics_pinn]="case=uniaxial seeds=3"
  [mechanics_convergence]="case=tbar reference=$ROOT/bench/data/tbar_twist_fem_reference.ply iters=400 out=$OUT/dem_convergence_tbar"
  # The solver matrix (hours on 2 cores; writes docs/mechanics_matrix.{csv,md,png}). MATRIX_ARGS
  # narrows it, e.g. MATRIX_ARGS=quick=1 for a smoke run.
  [mechanics_matrix]="out=$OUT/mechanics_matrix ${MATRIX_ARGS:-}"
)
# Entries that run another entry's binary with other arguments.
declare -A BINARIES=([mechanics_dem_tbar_grid]=mechanics_dem [nerf_train_fox]=nerf_train [nerf_train_fox_views]=nerf_train)
ORDER=(render_synth_bench geometry_sampling_bench nerf_kernels nerf_train nerf_train_fox nerf_train_fox_views geometry_tbar_extraction mechanics_cook mechanics_dem
       mechanics_dem_tbar_grid mechanics_pinn mechanics_convergence mechanics_matrix)
status=0
for name in ${BENCH:-${ORDER[@]}}; do
  binary=${BINARIES[$name]:-$name}
  if [ ! -x "$BIN/$binary" ]; then
    echo "== $name: not built (make bench builds it)"
    status=1
    continue
  fi
  echo "== $name ${COMMANDS[$name]:-}"
  # shellcheck disable=SC2086
  "$BIN/$binary" ${COMMANDS[$name]:-} || status=1
done
exit $status
