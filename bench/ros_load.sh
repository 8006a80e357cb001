#!/usr/bin/env bash
# Runs bench/ros_load.py with the catkin devel space of BUILD_DIR sourced and Debian's python3
# first on PATH. Usage: bash bench/ros_load.sh BUILD_DIR [--minutes N] [more ros_load.py flags]
set -euo pipefail
BUILD_DIR=$(cd "${1:?usage: bench/ros_load.sh BUILD_DIR [--minutes N]}" && pwd)
shift
export PATH="/usr/bin:$PATH"
set +u
# shellcheck disable=SC1091
source "$BUILD_DIR/devel/setup.bash"
set -u
exec /usr/bin/python3 "$(dirname "$0")/ros_load.py" --build "$BUILD_DIR" "$@"
