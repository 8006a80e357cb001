#!/usr/bin/env bash
# `make demo`: the main job on the bundled default (the T-bar), or on DATA=<dataset folder>
# (a real capture: with BOX=... or a <scenario>.box file naming the object's box, see README).
# Every stage's figures go to output/demo/<stage>.log (last line JSON) and into report.md.
set -uo pipefail
BUILD_DIR=${1:-build}
DATA=${2:-}
SOLVER=${SOLVER:-dem}          # dem (feature grid, seconds) | fem (linear tets, about a minute)
TRAIN_SECONDS=${TRAIN_SECONDS:-60}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
# The build folder as an absolute path (relative ones are taken from the repository root).
BUILD_DIR=$(cd "$ROOT" && realpath -m "$BUILD_DIR")
cd "$ROOT"
OUT="$ROOT/output/demo"
CLI="$BUILD_DIR/bin/demnerf"
SCENARIO=${SCENARIO:-config/scenarios/tbar_twist.yaml}
[[ $SCENARIO = /* ]] || SCENARIO="$ROOT/$SCENARIO"
# A real capture (DATA=...) holds more than the object: the box around it, in the scene's frame,
# is BOX=xmin,ymin,zmin,xmax,ymax,zmax or the scenario's sidecar file <scenario>.box (one line).
BOX=${BOX:-}
[ -n "$BOX" ] || [ ! -f "${SCENARIO%.yaml}.box" ] || BOX=$(grep -v '^#' "${SCENARIO%.yaml}.box" | head -n 1 | tr -d ' ')
CAPTURE_SECONDS=${CAPTURE_SECONDS:-300}   # NeRF training on a real capture (2 cores: 120-300 s)
CAPTURE_DOWNSCALE=${CAPTURE_DOWNSCALE:-4}  # the fox's 1080 x 1920 photos at 1/4
CAPTURE_SPACING=${CAPTURE_SPACING:-0.05}   # particle spacing in the scene's units (fox: ~1.5 across)
CAPTURE_SURFACE=${CAPTURE_SURFACE:-"--surface density --threshold 20"}  # fog-free on the fox; see README
# More `demnerf extract` flags for this capture: CAPTURE_EXTRACT=... or the scenario's sidecar file
# <scenario>.extract (one line). The fox's makes its sponge of a shell solid (--solid-radius, and
# --solid-cameras, which fills what none of its cameras, all in front, saw as empty; README, the
# fox section). {data} in the flags stands for the capture's folder (DATA).
# CAPTURE_EXTRACT= (set, empty) turns the sidecar off.
if [ -z "${CAPTURE_EXTRACT+set}" ] && [ -f "${SCENARIO%.yaml}.extract" ]; then
  CAPTURE_EXTRACT=$(grep -v '^#' "${SCENARIO%.yaml}.extract" | head -n 1)
fi
CAPTURE_EXTRACT=${CAPTURE_EXTRACT-}
CAPTURE_EXTRACT=${CAPTURE_EXTRACT//\{data\}/$DATA}
# A capture's extracted body is ragged (the fox's: ~6,000 particles, 5,000 of them on its surface):
# the DEM's set-up and Newton take ~55 s of an idle 2-core machine there, at the CLI's 60 s default.
CAPTURE_TIME_LIMIT=${CAPTURE_TIME_LIMIT:-180}
# CAPTURE_MODEL=<model.nerf>: skip training and use a model trained before on the same capture.
mkdir -p "$OUT"
REPORT="$OUT/report.md"
printf '# dem_nerf demo\n\n| stage | figures |\n| --- | --- |\n' > "$REPORT"

FAILED_STAGES=()  # the demo exits 1 when any stage failed (the later stages still run, for the report)
stage() {  # stage NAME COMMAND...: runs one stage, its figures or its failure go into the report
  local name=$1
  shift
  echo "== $name"
  "$@" --json > "$OUT/$name.log" 2> "$OUT/$name.err"
  local rc=$?
  if [ $rc -eq 0 ]; then
    tail -n 1 "$OUT/$name.log"
    printf '| %s | `%s` |\n' "$name" "$(tail -n 1 "$OUT/$name.log")" >> "$REPORT"
  else
    echo "   FAILED ($rc): $(tail -n 3 "$OUT/$name.err")"
    printf '| %s | failed: %s |\n' "$name" "$(tail -n 1 "$OUT/$name.err")" >> "$REPORT"
  fi
  [ $rc -eq 0 ] || FAILED_STAGES+=("$name")
  return $rc
}

BUNDLED=false
if [ -z "$DATA" ]; then
  BUNDLED=true
  DATA="$ROOT/output/tbar"
  [ -f "$DATA/transforms_train.json" ] || stage synth "$CLI" synth --scene tbar --out "$DATA"
fi
stage info "$CLI" info --data "$DATA"
# The bag feeds the ROS run only; a capture with a box goes through the CLI (capture_run below).
[ -n "$BOX" ] || stage bag "$CLI" bag --data "$DATA" --out "$OUT/dataset.bag"
# The ROS run, as on a rig: the bag replays the cameras into nerf_node, which trains for
# TRAIN_SECONDS, extracts the body and publishes particles; dem_node solves the scenario's twist on
# them; demo_recorder keeps both clouds as files and ends the launch.
ros_run() {
  echo "== ros (roslaunch dem_nerf tbar_demo.launch test:=true)"
  rm -f "$OUT/recorder.json" "$OUT/model.nerf" "$OUT/particles.ply" "$OUT/displaced.ply"
  (
    set +u
    export PATH="/usr/bin:$PATH"
    export ROS_HOME="$BUILD_DIR/ros_home_demo"
    export ROS_MASTER_URI=http://localhost:11399  # its own master, beside any other ROS session
    # shellcheck disable=SC1090,SC1091
    source "$BUILD_DIR/devel/setup.bash"
    roslaunch -p 11399 dem_nerf tbar_demo.launch test:=true out_dir:="$OUT" bag:="$OUT/dataset.bag" \
      scenario:="$SCENARIO" solver:="$SOLVER" model_path:="$OUT/model.nerf" train_seconds:="$TRAIN_SECONDS"
  ) > "$OUT/ros.log" 2>&1
  if [ -f "$OUT/recorder.json" ] && grep -q '"complete"' "$OUT/recorder.json"; then
    cat "$OUT/recorder.json"
    printf '| ros | `%s` |\n' "$(cat "$OUT/recorder.json")" >> "$REPORT"
    return 0
  fi
  echo "   FAILED: $(cat "$OUT/recorder.json" 2>/dev/null || tail -n 5 "$OUT/ros.log")"
  printf '| ros | failed: see ros.log |\n' >> "$REPORT"
  return 1
}
# A real capture with a box: the same job as the ROS run, stage by stage through the CLI, since
# the object is cut out of the scene by the box (demnerf extract --box) before sampling.
capture_run() {
  local nerf_config="$ROOT/packages/nerf/config/nerf_fox.yaml"
  [ -n "${CAPTURE_CONFIG:-}" ] && nerf_config=$CAPTURE_CONFIG
  if [ -n "${CAPTURE_MODEL:-}" ]; then  # a model trained earlier on the same capture: reused as is
    cp "$CAPTURE_MODEL" "$OUT/model.nerf" || return 1
  else
    stage train "$CLI" train --data "$DATA" --out "$OUT/model.nerf" --seconds "$CAPTURE_SECONDS" \
      --downscale "$CAPTURE_DOWNSCALE" --config "$nerf_config" || return 1
  fi
  stage extract "$CLI" extract --model "$OUT/model.nerf" --mesh "$OUT/mesh.ply" --box="$BOX" --resolution 128 $CAPTURE_SURFACE \
    $CAPTURE_EXTRACT || return 1
  stage sample "$CLI" sample --mesh "$OUT/mesh.ply" --spacing "$CAPTURE_SPACING" --out "$OUT/particles.ply" || return 1
  stage simulate "$CLI" simulate --particles "$OUT/particles.ply" --scenario "$SCENARIO" --solver "$SOLVER" \
    --out "$OUT/displaced.ply" --time-limit "$CAPTURE_TIME_LIMIT"
}
if [ -n "$BOX" ]; then
  rm -f "$OUT/model.nerf" "$OUT/mesh.ply" "$OUT/particles.ply" "$OUT/displaced.ply"
  capture_run || FAILED_STAGES+=(capture)
else
  ros_run || FAILED_STAGES+=(ros)
fi
SCALE=()  # a capture is evaluated and rendered at the resolution it was trained at
[ -z "$BOX" ] || SCALE=(--downscale "$CAPTURE_DOWNSCALE")
stage eval "$CLI" eval --model "$OUT/model.nerf" --data "$DATA" --split test "${SCALE[@]}"
TRUTH=()
if $BUNDLED && [ -f "$OUT/displaced.ply" ]; then
  # Ground truth: the exact T-bar moved by the same displacement, from the same cameras.
  stage truth "$CLI" synth --scene tbar --out "$OUT/truth" --result "$OUT/displaced.ply" && TRUTH=(--truth "$OUT/truth")
fi
stage render "$CLI" render --model "$OUT/model.nerf" --data "$DATA" --split test --out "$OUT/rendered" \
  --result "$OUT/displaced.ply" "${TRUTH[@]}" "${SCALE[@]}"
echo "demo outputs are in $OUT (report: $REPORT)"
if [ ${#FAILED_STAGES[@]} -gt 0 ]; then
  echo "demo: these stages failed: ${FAILED_STAGES[*]} (their .err files in $OUT say why)" >&2
  exit 1
fi
exit 0
