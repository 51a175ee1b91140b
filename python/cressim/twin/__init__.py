"""The dVRK PSM twin without ROS: batched arms that speak the dVRK's terms (`TwinArms`), their
scene file, and the sensor loop that renders off the control tick. The ROS 2 node
(ros_ws/src/cressim_ros) only wires topics to these objects; tests drive them directly.
"""
from cressim.twin.arms import TwinArms, TwinConfig
from cressim.twin.messages import ConfigError, Event, JointCommand, Snapshot, StateReport
from cressim.twin.sensor_loop import Sensor, SensorLoop
from cressim.twin_scene_file import DEFAULT_SCENE, Scene, SceneError, load_scene, parse_scene

__all__ = ["ConfigError", "DEFAULT_SCENE", "Event", "JointCommand", "Scene", "SceneError", "Sensor", "SensorLoop",
           "Snapshot", "StateReport", "TwinArms", "TwinConfig", "load_scene", "parse_scene"]
