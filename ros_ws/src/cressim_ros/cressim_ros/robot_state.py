"""What robot_state_publisher would give for the twin's arm, so RViz shows it with no extra node:
`/robot_description` (the URDF, latched), `/joint_states` (every URDF joint, mimic joints
included) and every link on `/tf` from its parent link. In batched mode env i's are
`/env{i}/robot_description`, `/env{i}/joint_states` and frames prefixed `env{i}/`.

The URDF names its links `PSM1_*`; for another arm name (`-p arm:=PSM2`) the description and the
frames say `PSM2_*`, matching the arm's `PSM2_base` on /tf_static. A patient cart's arms are named rows, each under
its own namespace: `/PSM2/robot_description`, `/PSM2/joint_states` (one RobotStateTopics for the
PSMs of an instrument, one FK for all of them, and one for the ECM).
"""
from __future__ import annotations

from array import array

from sensor_msgs.msg import JointState
from std_msgs.msg import String

from cressim.robots.kinematics import matrix_to_pose7

from .topics import LATCHED_QOS, ROBOT_DESCRIPTION_TOPIC, env_frame_prefix, env_topic, qos, TOPICS_BY_NAME

URDF_PREFIX = "PSM1_"


class RobotStateTopics:
    def __init__(self, node, arms, urdf_text: str, *, names: list[str] | None = None, bodies=None, state=None):
        """`arms`: a TwinArms (its num_envs, arm name, bodies and measured joints). A cart's arms
        are named rows, each under its own namespace and frame prefix (`names`: /PSM1, /PSM2 ...
        of a cart's PSMs, one batched FK for all); for the ECM also its `bodies` (ArmBodies) and
        `state()` -> (q (1, 6), jaw (1, 1)) tensors."""
        self.node, self.arms, self.num_envs = node, arms, arms.num_envs
        self.bodies = bodies or arms.bodies
        self.state = state or (lambda: (arms.measured, arms.jaw_meas))
        N = self.num_envs
        if names is not None:  # a cart's rows: /PSM2/..., frames PSM2_*, every one in env 0
            self.arm_names, self.env_prefixes = list(names), [""] * N
            self.topic = lambda name, env: f"/{names[env]}{name}"
            self.first_env_rows = list(range(N))
        else:
            self.arm_names, self.env_prefixes = [arms.arm] * N, [env_frame_prefix(env, N) for env in range(N)]
            self.topic = lambda name, env: env_topic(name, env, N)
            self.first_env_rows = [0]
        texts = {name: String(data=urdf_text.replace(URDF_PREFIX, f"{name}_")) for name in set(self.arm_names)}
        self.descriptions = [texts[name] for name in self.arm_names]
        self.description_pubs = [node.create_publisher(String, self.topic(ROBOT_DESCRIPTION_TOPIC, env), LATCHED_QOS)
                                 for env in range(N)]
        for pub, description in zip(self.description_pubs, self.descriptions):
            pub.publish(description)
        self.joint_pubs = [node.create_publisher(JointState, self.topic("/joint_states", env),
                                                 qos(TOPICS_BY_NAME["/joint_states"])) for env in range(N)]
        self._chain = self.bodies.arms[0] if hasattr(self.bodies, "arms") else self.bodies  # the URDF's chain (ArmRows: one for all)

    def frame(self, link: str, env: int) -> str:
        name = f"{self.arm_names[env]}_{link[len(URDF_PREFIX):]}" if link.startswith(URDF_PREFIX) else link
        return self.env_prefixes[env] + name

    def publish(self, stamp, transform, record=None) -> list:
        """Publishes every row's /joint_states; returns the link transforms for /tf (built by
        `transform(stamp, parent, child, pose7)`). One FK for all rows."""
        q, jaw = self.state()
        names, values = self._chain.urdf_joints(q, jaw)
        pairs, T = self._chain.link_transforms(q, jaw)
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
        """(topic, message) of the latched description of every row (a bag is self-contained)."""
        return [(self.topic(ROBOT_DESCRIPTION_TOPIC, env), self.descriptions[env]) for env in range(self.num_envs)]


__all__ = ["RobotStateTopics"]
