"""What robot_state_publisher would give for the twin's arm, so RViz shows it with no extra node:
`/robot_description` (the URDF, latched), `/joint_states` (every URDF joint, mimic joints
included) and every link on `/tf` from its parent link. In batched mode env i's are
`/env{i}/robot_description`, `/env{i}/joint_states` and frames prefixed `env{i}/`.

The URDF names its links `PSM1_*`; for another arm name (`-p arm:=PSM2`) the description and the
frames say `PSM2_*`, matching the arm's `PSM2_base` on /tf_static. A patient cart has one per arm
(the PSMs' and the ECM's), under the arm's namespace: `/PSM2/robot_description`,
`/PSM2/joint_states`.
"""
from __future__ import annotations

from array import array

import numpy as np
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from cressim.robots.kinematics import matrix_to_pose7

from .topics import LATCHED_QOS, ROBOT_DESCRIPTION_TOPIC, env_frame_prefix, env_topic, qos, TOPICS_BY_NAME

URDF_PREFIX = "PSM1_"


class RobotStateTopics:
    def __init__(self, node, arms, urdf_text: str, *, namespace: str = "", bodies=None, state=None):
        """`arms`: a TwinArms (its num_envs, arm name, bodies and measured joints); a cart's arm
        gives its `namespace`, and for the ECM its `bodies` (ArmBodies) and `state()` -> (q (1, 6),
        jaw (1, 1)) tensors."""
        self.node, self.arms, self.num_envs = node, arms, arms.num_envs
        self.bodies = bodies or arms.bodies
        self.state = state or (lambda: (arms.measured, arms.jaw_meas))
        self.prefix = f"{arms.arm}_"
        self.description = String(data=urdf_text.replace(URDF_PREFIX, self.prefix))
        N = self.num_envs
        self.topic = (lambda name, env: f"{namespace}{name}") if namespace else (
            lambda name, env: env_topic(name, env, N))
        self.description_pubs = [node.create_publisher(String, self.topic(ROBOT_DESCRIPTION_TOPIC, env), LATCHED_QOS)
                                 for env in range(N)]
        for pub in self.description_pubs:
            pub.publish(self.description)
        self.joint_pubs = [node.create_publisher(JointState, self.topic("/joint_states", env),
                                                 qos(TOPICS_BY_NAME["/joint_states"])) for env in range(N)]

    def frame(self, link: str, env: int) -> str:
        name = self.prefix + link[len(URDF_PREFIX):] if link.startswith(URDF_PREFIX) else link
        return env_frame_prefix(env, self.num_envs) + name

    def publish(self, stamp, transform, record=None) -> list:
        """Publishes every env's /joint_states; returns the link transforms for /tf (built by
        `transform(stamp, parent, child, pose7)`)."""
        q, jaw = self.state()
        names, values = self.bodies.urdf_joints(q, jaw)
        pairs, T = self.bodies.link_transforms(q, jaw)
        M, J = T.shape[:2]
        poses = matrix_to_pose7(T.reshape(-1, 4, 4)).reshape(M, J, 7).cpu().numpy()
        values = values.cpu().numpy()
        out = []
        for env in range(self.num_envs):
            m = JointState()
            m.header.stamp = stamp
            m.name = names
            m.position = array("d", values[env])
            self.joint_pubs[env].publish(m)
            if record is not None:
                record(self.topic("/joint_states", env), m)
            out += [transform(stamp, self.frame(a, env), self.frame(b, env), poses[env, k])
                    for k, (a, b) in enumerate(pairs)]
        return out

    def topics_for_recording(self):
        """(topic, message) of the latched description of every env (a bag is self-contained)."""
        return [(self.topic(ROBOT_DESCRIPTION_TOPIC, env), self.description) for env in range(self.num_envs)]


__all__ = ["RobotStateTopics"]
