#!/usr/bin/env bash
# The install check (not part of `make test`: it builds the whole package again, twice with
# --catkin-tools). In a fresh catkin workspace it clones this repository's committed HEAD into
# src/dem_nerf, runs `catkin_make install`, and from the install space alone (a clean
# environment that sources install/setup.bash) checks:
#   - the installed files: nodes, the demnerf CLI, libraries, headers, messages, launch, config;
#   - `roslaunch dem_nerf pipeline.launch`: nerf_node and dem_node start and advertise their topics;
#   - a downstream package (find_package(catkin COMPONENTS dem_nerf)) builds against the installed
#     libraries and messages, and its program writes a .vtu with them;
# and with --catkin-tools the same build by `catkin build` with an install space.
#
# Usage: scripts/check_install.sh [--catkin-tools] [WORKSPACE]   (default /work/install_ws)
# JOBS (default 2) sets the build's parallelism. With ccache on PATH the build goes through it;
# CCACHE_BASEDIR defaults to the workspace's parent so that two workspaces at the same depth share
# hits. The last line says PASSED or FAILED with the seconds each stage took.
set -uo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
CATKIN_TOOLS=0
if [ "${1:-}" = "--catkin-tools" ]; then CATKIN_TOOLS=1; shift; fi
WS=$(realpath -m "${1:-/work/install_ws}")
JOBS=${JOBS:-2}
PORT=$((11600 + RANDOM % 300))  # a master of its own, beside any rostest's
export PATH="/usr/bin:$PATH"    # Debian's python3 for catkin, whatever comes first on PATH

CMAKE_ARGS=(-DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3
            -DCATKIN_ENABLE_TESTING=OFF -DDEMNERF_BUILD_TESTS=OFF)
if command -v ccache > /dev/null; then
  CMAKE_ARGS+=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$(dirname "$WS")} CCACHE_NOHASHDIR=1
fi

timings=()
failures=()
stage_start=$SECONDS
finish_stage() { timings+=("$1 $((SECONDS - stage_start)) s"); stage_start=$SECONDS; }
fail() { echo "check_install: FAILED: $*" >&2; failures+=("$*"); }

# A clean environment with only the install space: nothing of this checkout's build leaks in.
# exec all the way down, so that `in_install_space ... &` leaves $! = the command's own process
# (a subshell in between would not pass on the SIGINT that stops roslaunch and roscore).
in_install_space() {
  exec env -i HOME="$HOME" PATH=/usr/local/bin:/usr/bin:/bin TERM=dumb ROS_HOME="$WS/ros_home" \
    ROS_MASTER_URI="http://localhost:$PORT" ROS_HOSTNAME=localhost \
    bash -c "source '$1/setup.bash' && $2"
}
# The same in the foreground (a subshell, so that exec does not end this script).
run_in_install_space() { (in_install_space "$@"); }

fresh_workspace() {
  rm -rf "$1" && mkdir -p "$1/src" && git clone -q "$ROOT" "$1/src/dem_nerf" || { fail "cannot clone $ROOT into $1"; return 1; }
  echo "check_install: $1/src/dem_nerf at $(git -C "$1/src/dem_nerf" log -1 --format='%h %s')"
}

check_installed_files() {
  local install=$1
  for f in lib/dem_nerf/dem_node lib/dem_nerf/nerf_node lib/dem_nerf/dataset_player lib/dem_nerf/demo_recorder \
           bin/demnerf lib/libdemnerf_core.a lib/libdemnerf_mechanics.a lib/libdemnerf_vtk_export.a \
           include/demnerf/core/ply.hpp include/demnerf/vtk_export/vtu_writer.hpp include/dem_nerf/TrainingStatus.h \
           include/dem_nerf/Solve.h share/dem_nerf/package.xml share/dem_nerf/launch/pipeline.launch \
           share/dem_nerf/config/solvers.yaml share/dem_nerf/config/scenarios/tbar_twist.yaml \
           share/dem_nerf/msg/Load.msg share/dem_nerf/cmake/dem_nerfConfig.cmake share/dem_nerf/cmake/dem_nerf-extras.cmake; do
    [ -e "$install/$f" ] || fail "not installed: $f"
  done
  local found
  found=$(run_in_install_space "$install" "rospack find dem_nerf")
  [ "$found" = "$install/share/dem_nerf" ] || fail "rospack finds dem_nerf at '$found', not in the install space"
  run_in_install_space "$install" "demnerf simulate --help" | grep -q -- "--vtu" || fail "installed demnerf has no simulate --vtu"
}

# roscore, then the pipeline from the install space; the nodes must register and advertise.
check_launch() {
  local install=$1 log="$WS/launch.log"
  in_install_space "$install" "exec roscore -p $PORT" > "$WS/roscore.log" 2>&1 &
  local core=$!
  sleep 4
  in_install_space "$install" "exec roslaunch dem_nerf pipeline.launch" > "$log" 2>&1 &
  local launch=$!
  local nodes="" topics="" expected_topics="/dem_node/displaced /dem_node/status /dem_node/markers /nerf_node/particles /nerf_node/status"
  for _ in $(seq 60); do
    sleep 1
    nodes=$(run_in_install_space "$install" "rosnode list" 2>/dev/null)
    topics=$(run_in_install_space "$install" "rostopic list" 2>/dev/null)
    local missing=0
    for t in $expected_topics; do grep -qx "$t" <<< "$topics" || missing=1; done
    grep -qx /dem_node <<< "$nodes" && grep -qx /nerf_node <<< "$nodes" && [ $missing -eq 0 ] && break
  done
  echo "check_install: nodes: $(tr '\n' ' ' <<< "$nodes")"
  for n in /dem_node /nerf_node; do grep -qx "$n" <<< "$nodes" || fail "node $n did not start (see $log)"; done
  for t in $expected_topics; do grep -qx "$t" <<< "$topics" || fail "topic $t not advertised (see $log)"; done
  # The launch must not have found its files in the source tree (it has none in a clean env).
  grep -q "$install/share/dem_nerf/config/scenarios/tbar_twist.yaml" <<< \
    "$(run_in_install_space "$install" "rosparam get /dem_node/scenario" 2>/dev/null)" || fail "dem_node's scenario is not the installed one"
  kill -INT "$launch" 2> /dev/null; wait "$launch" 2> /dev/null
  kill -INT "$core" 2> /dev/null; wait "$core" 2> /dev/null
}

# A package that uses the installed libraries and messages, built in a workspace of its own.
check_downstream() {
  local install=$1 ws="$WS/downstream_ws"
  rm -rf "$ws" && mkdir -p "$ws/src/dem_nerf_user"
  cat > "$ws/src/dem_nerf_user/package.xml" << 'XML'
<?xml version="1.0"?>
<package format="3">
  <name>dem_nerf_user</name><version>0.0.1</version><description>uses dem_nerf's exports</description>
  <maintainer email="check@example.com">check</maintainer><license>BSD-3-Clause</license>
  <buildtool_depend>catkin</buildtool_depend><depend>dem_nerf</depend>
</package>
XML
  cat > "$ws/src/dem_nerf_user/CMakeLists.txt" << 'CMAKE'
cmake_minimum_required(VERSION 3.16)
project(dem_nerf_user CXX)
set(CMAKE_CXX_STANDARD 17)
find_package(catkin REQUIRED COMPONENTS dem_nerf)
catkin_package()
add_executable(box_to_vtu box_to_vtu.cpp)
target_include_directories(box_to_vtu PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(box_to_vtu ${catkin_LIBRARIES})
CMAKE
  cat > "$ws/src/dem_nerf_user/box_to_vtu.cpp" << 'CPP'
// Particles of a box written for ParaView through the installed libraries; a message type too.
#include <dem_nerf/TrainingStatus.h>
#include <cstdio>
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/vtk_export/vtu_writer.hpp"
int main(int argc, char** argv) {
  const auto cloud = demnerf::mechanics::makeBoxParticles(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, 0.02, 0.02), Eigen::Vector3i(10, 2, 2));
  demnerf::core::ResultField result;
  result.resize(cloud.size());
  result.positions = cloud.positions;
  demnerf::vtk_export::writeParticlesVtu(argv[1], cloud, result);
  dem_nerf::TrainingStatus status;
  status.stage = "ok";
  std::printf("%zu particles written, status %s\n", cloud.size(), status.stage.c_str());
  return argc == 2 ? 0 : 1;
}
CPP
  run_in_install_space "$install" "cd '$ws' && catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release" \
    > "$ws/build.log" 2>&1 || { fail "a downstream package does not build against the install space (see $ws/build.log)"; return; }
  run_in_install_space "$install" "'$ws/devel/lib/dem_nerf_user/box_to_vtu' '$ws/box.vtu'" && grep -q UnstructuredGrid "$ws/box.vtu" \
    || fail "the downstream program did not write its .vtu"
}

echo "check_install: catkin_make install in $WS (-j$JOBS${CCACHE_BASEDIR:+, ccache with CCACHE_BASEDIR=$CCACHE_BASEDIR})"
if fresh_workspace "$WS"; then
  (cd "$WS" && catkin_make install -j"$JOBS" "${CMAKE_ARGS[@]}" > "$WS/catkin_make.log" 2>&1) \
    || fail "catkin_make install failed: see $WS/catkin_make.log ($(tail -3 "$WS/catkin_make.log" | tr '\n' ' '))"
  finish_stage "catkin_make install:"
  if [ -f "$WS/install/setup.bash" ]; then
    check_installed_files "$WS/install"
    check_launch "$WS/install"
    finish_stage "installed files + roslaunch:"
    check_downstream "$WS/install"
    finish_stage "downstream package:"
  fi
fi

if [ $CATKIN_TOOLS -eq 1 ]; then
  CT="${WS}_catkin_tools"
  echo "check_install: catkin build in $CT"
  if ! command -v catkin > /dev/null; then
    fail "catkin-tools is not installed (make setup installs it)"
  elif fresh_workspace "$CT"; then
    (cd "$CT" && catkin init -q > /dev/null && catkin config -q --install --cmake-args "${CMAKE_ARGS[@]}" > /dev/null &&
      catkin build --no-status --no-notify -j"$JOBS" > "$CT/catkin_build.log" 2>&1) \
      || fail "catkin build failed: see $CT/catkin_build.log ($(tail -3 "$CT/catkin_build.log" | tr '\n' ' '))"
    finish_stage "catkin build:"
    [ -f "$CT/install/setup.bash" ] && check_installed_files "$CT/install"
  fi
fi

echo "check_install: ${timings[*]}"
if [ ${#failures[@]} -eq 0 ]; then
  echo "check_install: PASSED"
else
  echo "check_install: FAILED (${#failures[@]}): ${failures[*]}"
  exit 1
fi
