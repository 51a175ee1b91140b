# Source me (bash): `source ros_ws/env.sh` after `ros_ws/build.sh [VENV]`.
# Makes the ROS 2 wheels in VENV and the packages built into ros_ws/install usable:
#   PATH               VENV/bin first (so `python` has rclpy), then ros_ws/install/bin (cressim_twin)
#   PYTHONPATH         ros_ws/install/lib/python3.11/site-packages (crtk_msgs Python package)
#   LD_LIBRARY_PATH    ros_ws/install/lib (crtk_msgs typesupport libraries) and VENV/lib
#   AMENT_PREFIX_PATH  ros_ws/install:VENV
# VENV is the one build.sh used (install/.cressim-venv), else $CRESSIM_ROS_VENV, else
# $VIRTUAL_ENV, else <repo>/.venv-ros. The wheels' own ros_wheels_bootstrapper re-execs python
# once with VENV/lib and ros_*.libs on LD_LIBRARY_PATH, keeping what is set here.

_cressim_ws="$(cd "$(dirname "${BASH_SOURCE[0]:-${CRESSIM_ROS_WS:-ros_ws}/env.sh}")" && pwd)"
_cressim_install="$_cressim_ws/install"
if [ -f "$_cressim_install/.cressim-venv" ]; then
  _cressim_venv="$(cat "$_cressim_install/.cressim-venv")"
else
  _cressim_venv="${CRESSIM_ROS_VENV:-${VIRTUAL_ENV:-$(dirname "$_cressim_ws")/.venv-ros}}"
fi

_cressim_prepend() {  # _cressim_prepend VAR DIR: put DIR first in VAR (once)
  local cur
  eval "cur=\${$1:-}"
  case ":$cur:" in *":$2:"*) return 0 ;; esac
  if [ -n "$cur" ]; then export "$1=$2:$cur"; else export "$1=$2"; fi
}

if [ ! -d "$_cressim_install/lib" ]; then
  echo "ros_ws/env.sh: $_cressim_install not built; run ros_ws/build.sh first" >&2
fi
if [ ! -x "$_cressim_venv/bin/python" ]; then
  echo "ros_ws/env.sh: virtualenv $_cressim_venv not found" >&2
fi

_cressim_prepend PATH "$_cressim_install/bin"
_cressim_prepend PATH "$_cressim_venv/bin"
_cressim_prepend LD_LIBRARY_PATH "$_cressim_venv/lib"
_cressim_prepend LD_LIBRARY_PATH "$_cressim_install/lib"
_cressim_prepend AMENT_PREFIX_PATH "$_cressim_venv"
_cressim_prepend AMENT_PREFIX_PATH "$_cressim_install"
_cressim_prepend CMAKE_PREFIX_PATH "$_cressim_venv"
_cressim_prepend CMAKE_PREFIX_PATH "$_cressim_install"
_cressim_prepend PYTHONPATH "$_cressim_install/lib/python3.11/site-packages"
export CRESSIM_ROS_WS="$_cressim_ws"
export CRESSIM_ROS_VENV="$_cressim_venv"
# Fast DDS over loopback works without extra settings; tests pick their own ROS_DOMAIN_ID.
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"

unset -f _cressim_prepend
unset _cressim_ws _cressim_install _cressim_venv
