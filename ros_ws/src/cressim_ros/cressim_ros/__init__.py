"""cressim_ros: the ROS 2 digital twin of the dVRK PSM on the cressim engine (docs/twin.md).

Run: `cressim_twin` (after ros_ws/build.sh and `source ros_ws/env.sh`) or `python -m cressim_ros`,
with ROS parameters: `--ros-args -p num_envs:=2 -p publish_rate:=100.0`.
"""
