#!/usr/bin/env bash
# The README's rviz picture: the T-bar demo with gui:=true on a virtual display (Xvfb), captured
# once dem_node has published the twisted T-bar. Needs a finished `make demo` (it resumes the
# model nerf_node saved in output/demo) and the Debian packages xvfb, x11-apps and netpbm, which it
# installs when missing (apt-get; sudo when not root).
#   scripts/rviz_screenshot.sh [BUILD_DIR] [OUT.png]
set -uo pipefail
BUILD_DIR=${1:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
# The build folder as an absolute path (relative ones are taken from the repository root).
BUILD_DIR=$(cd "$ROOT" && realpath -m "$BUILD_DIR")
PNG=${2:-$ROOT/docs/rviz_tbar_twist.png}
MODEL="$ROOT/output/demo/model.nerf"
[ -f "$MODEL" ] || { echo "no $MODEL: run make demo first" >&2; exit 1; }
if ! command -v Xvfb > /dev/null || ! command -v xwd > /dev/null || ! command -v xwdtopnm > /dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO=sudo
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q xvfb x11-apps netpbm > /dev/null || exit 1
fi
DISPLAY_NUMBER=:97
Xvfb $DISPLAY_NUMBER -screen 0 1280x720x24 > /dev/null 2>&1 &
XVFB=$!
trap 'kill $LAUNCH $XVFB 2> /dev/null; wait 2> /dev/null' EXIT
set +u
export PATH="/usr/bin:$PATH" DISPLAY=$DISPLAY_NUMBER LIBGL_ALWAYS_SOFTWARE=1
export ROS_HOME="$BUILD_DIR/ros_home_screenshot" ROS_MASTER_URI=http://localhost:11398
# shellcheck disable=SC1091
source "$BUILD_DIR/devel/setup.bash"
set -u
# A copy of the model, so the resumed training does not touch the demo's own file.
cp "$MODEL" /tmp/dem_nerf_screenshot.nerf
roslaunch -p 11398 dem_nerf tbar_demo.launch gui:=true model_path:=/tmp/dem_nerf_screenshot.nerf train_seconds:=5 \
  bag:="$ROOT/output/demo/dataset.bag" > "$BUILD_DIR/rviz_screenshot.log" 2>&1 &
LAUNCH=$!
# The displaced cloud is dem_node's answer; then give rviz a moment to draw it.
# rostopic fails at once until the master is up, so it is retried.
deadline=$((SECONDS + 600))
until timeout 30 rostopic echo -n 1 /dem_node/displaced/width > /dev/null 2>&1; do
  if [ $SECONDS -gt $deadline ]; then
    echo "dem_node published no displaced cloud within 10 min (see $BUILD_DIR/rviz_screenshot.log)" >&2
    exit 1
  fi
  sleep 2
done
sleep 15
xwd -root -display $DISPLAY_NUMBER -silent > /tmp/dem_nerf_rviz.xwd
xwdtopnm /tmp/dem_nerf_rviz.xwd 2> /dev/null | pnmtopng > "$PNG" || exit 1
echo "wrote $PNG"
