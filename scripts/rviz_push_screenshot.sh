#!/usr/bin/env bash
# The README's "Push the object in rviz" picture, headless: dem_node with ~interactive on the test
# cantilever (test/data/cuboid_test.yaml, FEM), rviz with config/interactive.rviz (its view moved
# onto the 0.1 m bar) on a virtual display, and scripts/push_demo_driver.py dragging the push
# marker's arrow 3 cm down as a user would; captured once dem_node has answered. Needs the Debian
# packages xvfb, x11-apps, netpbm and python3-visualization-msgs (the driver), which it installs when missing (apt-get; sudo when not root).
#   scripts/rviz_push_screenshot.sh [BUILD_DIR] [OUT.png]
set -uo pipefail
BUILD_DIR=${1:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD_DIR=$(cd "$ROOT" && realpath -m "$BUILD_DIR")
PNG=${2:-$ROOT/docs/rviz_push.png}
if ! command -v Xvfb > /dev/null || ! command -v xwd > /dev/null || ! command -v xwdtopnm > /dev/null ||
    ! /usr/bin/python3 -c "import visualization_msgs" 2> /dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO=sudo
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q xvfb x11-apps netpbm python3-visualization-msgs > /dev/null || exit 1
fi
DISPLAY_NUMBER=:96
PORT=11396
Xvfb $DISPLAY_NUMBER -screen 0 1280x720x24 > /dev/null 2>&1 &
XVFB=$!
LAUNCH="" DRIVER=""
trap 'kill $DRIVER $LAUNCH $XVFB 2> /dev/null; wait 2> /dev/null' EXIT
set +u
export PATH="/usr/bin:$PATH" DISPLAY=$DISPLAY_NUMBER LIBGL_ALWAYS_SOFTWARE=1
export ROS_HOME="$BUILD_DIR/ros_home_push_screenshot" ROS_MASTER_URI=http://localhost:$PORT
# shellcheck disable=SC1091
source "$BUILD_DIR/devel/setup.bash"
set -u
# interactive.rviz looks at the T-bar; the cantilever is 0.1 m long at the origin.
RVIZ=/tmp/dem_nerf_push_screenshot.rviz
sed -e 's/Distance: 1.2/Distance: 0.22/' -e 's/Focal Point: {X: 0, Y: 0, Z: 0.15}/Focal Point: {X: 0.05, Y: 0, Z: -0.01}/' \
  -e 's/Cell Size: 0.1/Cell Size: 0.01/' "$ROOT/config/interactive.rviz" > $RVIZ
cat > /tmp/dem_nerf_push_screenshot.launch << LAUNCH_FILE
<launch>
  <node pkg="dem_nerf" type="dem_node" name="dem_node">
    <param name="scenario" value="$ROOT/test/data/cuboid_test.yaml"/>
    <param name="solver" value="fem"/>
    <param name="fem_order" value="1"/>
    <param name="contact_radius" value="0.015"/>
    <param name="interactive" value="true"/>
  </node>
  <node pkg="rviz" type="rviz" name="rviz" args="-d $RVIZ"/>
</launch>
LAUNCH_FILE
roslaunch -p $PORT /tmp/dem_nerf_push_screenshot.launch > "$BUILD_DIR/rviz_push_screenshot.log" 2>&1 &
LAUNCH=$!
sleep 8  # the master, dem_node and rviz up
python3 "$ROOT/scripts/push_demo_driver.py" --drag 0.03 >> "$BUILD_DIR/rviz_push_screenshot.log" 2>&1 &
DRIVER=$!
deadline=$((SECONDS + 120))
until timeout 10 rostopic echo -n 1 /dem_node/displaced/width > /dev/null 2>&1; do
  if [ $SECONDS -gt $deadline ]; then
    echo "dem_node published no displaced cloud within 2 min (see $BUILD_DIR/rviz_push_screenshot.log)" >&2
    exit 1
  fi
done
sleep 10  # rviz draws the cloud and the markers (software rendering)
mkdir -p "$(dirname "$PNG")"
xwd -root -display $DISPLAY_NUMBER | xwdtopnm 2> /dev/null | pnmtopng > "$PNG" && echo "wrote $PNG"
