"""A dVRK-style Python client, written from the behaviour in shared/DVRK.md (not the dVRK's code).

It does what the dVRK's Python clients (crtk/dvrk `arm` objects) do, so that a twin that runs
it to the end drives unmodified ones too:
- one node, spun on a background thread; the arm's topics under its namespace, with the
  dVRK's QoS; `check_connections` waits until every topic it publishes or subscribes has a
  peer (clients refuse to start otherwise);
- `enable`/`home` publish a state_command and wait for an operating_state stamped after the
  command with the state wanted (ENABLED; is_homed and not is_busy);
- `move_jp`/`move_cp`/`jaw.move_jp` return a handle whose `wait` blocks until an
  operating_state stamped after the command says is_busy=false (having seen is_busy=true);
- `measured_jp` and friends raise when the newest sample is older than a few periods
  (clients time out after 1-5 s without data).
Times are the client's own clock, compared with the twin's stamps (one machine, one clock).
"""
from __future__ import annotations

import threading
import time

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, String

from crtk_msgs.msg import OperatingState, StringStamped

PERIODIC = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
EVENT = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
COMMAND = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)


def stamp_s(header) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


class Ral:
    """ROS abstraction layer: a context, a node and an executor thread of their own."""

    def __init__(self, name: str, domain_id: int):
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.publishers, self.subscriptions = [], []
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self):
        try:
            self.executor.spin()
        except (ExternalShutdownException, rclpy.executors.ShutdownException):
            pass

    def publisher(self, msg_type, topic, qos):
        pub = self.node.create_publisher(msg_type, topic, qos)
        self.publishers.append(pub)
        return pub

    def subscriber(self, msg_type, topic, callback, qos):
        sub = self.node.create_subscription(msg_type, topic, callback, qos)
        self.subscriptions.append(sub)
        return sub

    def check_connections(self, timeout: float = 10.0):
        """Waits until every publisher has a subscriber and every subscription a publisher."""
        deadline = time.monotonic() + timeout
        while True:
            missing = [p.topic_name for p in self.publishers if p.get_subscription_count() == 0]
            missing += [s.topic_name for s in self.subscriptions if self.node.count_publishers(s.topic_name) == 0]
            if not missing:
                return
            if time.monotonic() > deadline:
                raise TimeoutError(f"no peer for {missing} after {timeout} s")
            time.sleep(0.05)

    def now(self) -> float:
        return time.time()

    def shutdown(self):
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)
        self.thread.join(timeout=5.0)


class _Latest:
    """The newest message of a topic, with a condition to wait on, and optionally a history."""

    def __init__(self, keep: int = 0):
        self.cond = threading.Condition()
        self.msg, self.count, self.history, self.keep = None, 0, [], keep
        self.arrivals = []  # client receive times (monotonic), for rate checks

    def __call__(self, msg):
        with self.cond:
            self.msg = msg
            self.count += 1
            self.arrivals.append(time.monotonic())
            if len(self.arrivals) > 5000:
                del self.arrivals[:2500]
            if self.keep:
                self.history.append(msg)
                if len(self.history) > self.keep:
                    del self.history[: -self.keep]
            self.cond.notify_all()

    def wait_for(self, predicate, timeout):
        with self.cond:
            return self.cond.wait_for(lambda: self.msg is not None and predicate(self.msg), timeout)

    def rate(self, window: float) -> float:
        """Messages per second received over the last `window` seconds."""
        now = time.monotonic()
        with self.cond:
            n = sum(1 for t in self.arrivals if now - t <= window)
        return n / window


class MoveHandle:
    def __init__(self, arm, start: float):
        self.arm, self.start = arm, start

    def wait(self, timeout: float = 30.0) -> bool:
        """True once the twin said busy and then not busy, both stamped after the command."""
        state = self.arm._state
        deadline = time.monotonic() + timeout
        saw_busy = state.wait_for(lambda m: any(stamp_s(h.header) > self.start and h.is_busy
                                                for h in state.history), timeout)
        if not saw_busy:
            return False
        return state.wait_for(lambda m: stamp_s(m.header) > self.start and not m.is_busy,
                              max(0.0, deadline - time.monotonic()))


class _Jaw:
    def __init__(self, arm, ns):
        ral = arm.ral
        self.arm = arm
        self._measured = _Latest()
        ral.subscriber(JointState, f"{ns}/jaw/measured_js", self._measured, PERIODIC)
        self._move = ral.publisher(JointState, f"{ns}/jaw/move_jp", COMMAND)
        self._servo = ral.publisher(JointState, f"{ns}/jaw/servo_jp", COMMAND)

    def measured_jp(self, age: float | None = None) -> np.ndarray:
        return np.array(self.arm._fresh(self._measured, age, "jaw/measured_js").position)

    def move_jp(self, q) -> MoveHandle:
        start = self.arm.ral.now()
        self._move.publish(JointState(position=[float(v) for v in np.atleast_1d(q)]))
        return MoveHandle(self.arm, start)

    def servo_jp(self, q):
        self._servo.publish(JointState(position=[float(v) for v in np.atleast_1d(q)]))


class Arm:
    def __init__(self, ral: Ral, ns: str = "/PSM1", stale_after: float = 0.5):
        """`stale_after`: the age (s) past which a reading raises, the dVRK clients' 0.5 s by default."""
        self.ral, self.ns, self.stale_after = ral, ns, stale_after
        self._state = _Latest(keep=200)
        # a few seconds of joint states, to pair each tick's measured and setpoint (same stamp)
        self._measured_js, self._setpoint_js = _Latest(keep=1000), _Latest(keep=1000)
        self._measured_cp, self._setpoint_cp = _Latest(), _Latest()
        self._spatial_cf = None  # subscribed on first use: not every twin publishes the wrench group
        self.goal_reached, self.errors, self.warnings = _Latest(keep=200), _Latest(keep=500), _Latest(keep=200)
        ral.subscriber(OperatingState, f"{ns}/operating_state", self._state, EVENT)
        ral.subscriber(JointState, f"{ns}/measured_js", self._measured_js, PERIODIC)
        ral.subscriber(JointState, f"{ns}/setpoint_js", self._setpoint_js, PERIODIC)
        ral.subscriber(PoseStamped, f"{ns}/measured_cp", self._measured_cp, PERIODIC)
        ral.subscriber(PoseStamped, f"{ns}/setpoint_cp", self._setpoint_cp, PERIODIC)
        ral.subscriber(Bool, f"{ns}/goal_reached", self.goal_reached, EVENT)
        ral.subscriber(String, f"{ns}/error", self.errors, EVENT)
        ral.subscriber(String, f"{ns}/warning", self.warnings, EVENT)
        self._state_command = ral.publisher(StringStamped, f"{ns}/state_command", COMMAND)
        self._servo_jp = ral.publisher(JointState, f"{ns}/servo_jp", COMMAND)
        self._move_jp = ral.publisher(JointState, f"{ns}/move_jp", COMMAND)
        self._servo_cp = ral.publisher(PoseStamped, f"{ns}/servo_cp", COMMAND)
        self._move_cp = ral.publisher(PoseStamped, f"{ns}/move_cp", COMMAND)
        self.jaw = _Jaw(self, ns)

    # ---- state
    def operating_state(self) -> OperatingState | None:
        return self._state.msg

    def _command(self, cmd: str) -> float:
        start = self.ral.now()
        msg = StringStamped(string=cmd)
        msg.header.stamp = self.ral.node.get_clock().now().to_msg()
        self._state_command.publish(msg)
        return start

    def enable(self, timeout: float = 5.0) -> bool:
        start = self._command("enable")
        return self._state.wait_for(lambda m: stamp_s(m.header) > start and m.state == "ENABLED", timeout)

    def disable(self, timeout: float = 5.0) -> bool:
        start = self._command("disable")
        return self._state.wait_for(lambda m: stamp_s(m.header) > start and m.state == "DISABLED", timeout)

    def home(self, timeout: float = 10.0) -> bool:
        start = self._command("home")
        return self._state.wait_for(lambda m: stamp_s(m.header) > start and m.is_homed and not m.is_busy
                                    and m.state == "ENABLED", timeout)

    # ---- data (raise when stale, like the dVRK clients)
    def _fresh(self, latest: _Latest, age: float | None, name: str):
        msg = latest.msg
        if msg is None:
            raise RuntimeError(f"{self.ns}/{name}: no data received")
        age = self.stale_after if age is None else age
        lag = self.ral.now() - stamp_s(msg.header)
        if lag > age:
            raise RuntimeError(f"{self.ns}/{name}: newest sample is {lag:.3f} s old")
        return msg

    def measured_jp(self, age: float | None = None) -> np.ndarray:
        return np.array(self._fresh(self._measured_js, age, "measured_js").position)

    def measured_jv(self, age: float | None = None) -> np.ndarray:
        return np.array(self._fresh(self._measured_js, age, "measured_js").velocity)

    def setpoint_jp(self, age: float | None = None) -> np.ndarray:
        return np.array(self._fresh(self._setpoint_js, age, "setpoint_js").position)

    def measured_cp(self, age: float | None = None) -> np.ndarray:
        return pose_to_matrix(self._fresh(self._measured_cp, age, "measured_cp").pose)

    def spatial_measured_cf(self, age: float | None = None, timeout: float = 10.0) -> np.ndarray:
        """Force (N) and torque (N m) on the tool about its tip, in the measured_cp frame."""
        if self._spatial_cf is None:
            self._spatial_cf = _Latest()
            self.ral.subscriber(WrenchStamped, f"{self.ns}/spatial/measured_cf", self._spatial_cf, PERIODIC)
            self._spatial_cf.wait_for(lambda m: True, timeout)
        w = self._fresh(self._spatial_cf, age, "spatial/measured_cf").wrench
        return np.array([w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z])

    def measured_jp_and_cp(self, timeout: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """measured_js positions and the measured_cp matrix of one tick (equal stamps): the two
        newest messages may come from neighbouring ticks while the arm still moves."""
        deadline = time.monotonic() + timeout
        while True:
            js, cp = self._fresh(self._measured_js, 0.5, "measured_js"), self._fresh(self._measured_cp, 0.5, "measured_cp")
            if js.header.stamp == cp.header.stamp:
                return np.array(js.position), pose_to_matrix(cp.pose)
            if time.monotonic() > deadline:
                raise RuntimeError(f"{self.ns}: measured_js and measured_cp never carried the same stamp")
            time.sleep(0.001)

    def joint_states_since(self, start: float) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """(stamp, setpoint, measured) positions of every tick since `start` that both topics
        reported: what the twin's arm did with its command in that tick, whatever the wall clock."""
        with self._setpoint_js.cond:
            setpoints = {stamp_s(m.header): m.position for m in self._setpoint_js.history}
        with self._measured_js.cond:
            measured = [m for m in self._measured_js.history if stamp_s(m.header) > start]
        return [(stamp_s(m.header), np.array(setpoints[stamp_s(m.header)]), np.array(m.position))
                for m in measured if stamp_s(m.header) in setpoints]

    def measured_js_rate(self, window: float = 1.0) -> float:
        return self._measured_js.rate(window)

    def wait_measured(self, samples: int, timeout: float) -> bool:
        """Wait for `samples` more measured_js messages: the twin publishes one per tick, so this
        waits a span of simulated time however slowly the machine runs it."""
        latest = self._measured_js
        with latest.cond:
            target = latest.count + samples
            return latest.cond.wait_for(lambda: latest.count >= target, timeout)

    # ---- motion
    def servo_jp(self, q):
        self._servo_jp.publish(JointState(position=[float(v) for v in q]))

    def move_jp(self, q) -> MoveHandle:
        start = self.ral.now()
        self._move_jp.publish(JointState(position=[float(v) for v in q]))
        return MoveHandle(self, start)

    def servo_cp(self, T):
        self._servo_cp.publish(matrix_to_pose_stamped(T))

    def move_cp(self, T) -> MoveHandle:
        start = self.ral.now()
        self._move_cp.publish(matrix_to_pose_stamped(T))
        return MoveHandle(self, start)

    def states_since(self, start: float) -> list:
        with self._state.cond:
            return [m for m in self._state.history if stamp_s(m.header) > start]


def pose_to_matrix(pose) -> np.ndarray:
    x, y, z, w = pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = pose.position.x, pose.position.y, pose.position.z
    return T


def matrix_to_pose_stamped(T) -> PoseStamped:
    T = np.asarray(T, dtype=np.float64)
    R = T[:3, :3]
    w = np.sqrt(max(0.0, 1.0 + np.trace(R))) / 2
    if w > 1e-3:
        x, y, z = (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)
    else:  # near 180 degrees: from the largest diagonal element
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        v = np.zeros(3)
        v[i] = np.sqrt(max(0.0, 1 + R[i, i] - R[j, j] - R[k, k])) / 2
        v[j] = (R[j, i] + R[i, j]) / (4 * v[i])
        v[k] = (R[k, i] + R[i, k]) / (4 * v[i])
        w = (R[k, j] - R[j, k]) / (4 * v[i])
        x, y, z = v
    msg = PoseStamped()
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in T[:3, 3])
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = float(x), float(y), float(z), float(w)
    return msg
