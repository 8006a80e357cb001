#!/usr/bin/env bash
# Installs every Debian package dem_nerf needs. Idempotent: quiet when all is there.
set -euo pipefail

PACKAGES=(
  # build tools
  build-essential cmake pkg-config
  # ROS 1 from Debian
  ros-base-dev catkin python3-catkin-pkg python3-rostest python3-roslaunch python3-rosbag
  python3-rostopic python3-rosservice python3-rosnode rosbash
  librosbag-dev libroscpp-dev ros-message-generation ros-std-msgs libstd-msgs-dev
  libsensor-msgs-dev libgeometry-msgs-dev libvisualization-msgs-dev libstd-srvs-dev
  libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev libtf2-msgs-dev python3-tf2-ros
  libimage-transport-dev libcv-bridge-dev libpcl-conversions-dev libdiagnostic-updater-dev
  # roscpp's CMake config links -lboost_chrono without its -dev package depending on it
  libboost-chrono-dev
  rviz
  # dem_node's live settings and interactive push
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure libinteractive-markers-dev
  # numerics, learning, geometry, vision
  libtorch-dev libopenblas0-pthread libeigen3-dev libpcl-dev libopencv-dev libcgal-dev
  libyaml-cpp-dev nlohmann-json3-dev
  # ParaView export (vtkXMLUnstructuredGridWriter); libpcl-dev pulls it in too, named here as used
  libvtk9-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev python3-sensor-msgs
  # scripts/check_install.sh: `catkin build` of a fresh workspace
  catkin-tools
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/tmp/dem_nerf_setup.log 2>&1 || {
  echo "setup: apt-get install failed; last lines of /tmp/dem_nerf_setup.log:" >&2
  tail -20 /tmp/dem_nerf_setup.log >&2
  exit 1
}
echo "setup: done"
