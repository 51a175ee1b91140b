"""Bad commands are refused with a reason on `error`, and the twin keeps publishing.

One twin for the module (start-up costs seconds on lavapipe); tests run in file order: the
ones that need a DISABLED arm come first, then the arm is enabled and homed.
"""
import math
import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty

from twin_fixtures import keeps_publishing, module_twin

pytestmark = pytest.mark.ros

@pytest.fixture(scope="module")
def client(request, tmp_path_factory, twin_domain):
    from cressim_ros.dvrk_client import Arm, Ral

    twin = module_twin(request, tmp_path_factory, twin_domain)
    ral = Ral("refusal_client", twin_domain)
    arm = Arm(ral, "/PSM1")
    ral.check_connections(timeout=20)
    assert arm._measured_js.wait_for(lambda m: True, 5)
    assert arm._state.wait_for(lambda m: True, 5), "no operating_state (transient local) after connecting"
    yield twin, ral, arm
    ral.shutdown()
    assert twin.alive(), twin.output()


def expect_error(arm, send, *words, timeout=3.0):
    """Runs send(), waits for a new `error` message containing all words; returns its text."""
    before = arm.errors.count
    send()
    ok = arm.errors.wait_for(lambda m: arm.errors.count > before and all(w in m.data for w in words), timeout)
    seen = [m.data for m in arm.errors.history[-5:]]
    assert ok, f"no error containing {words}; last errors: {seen}"
    time.sleep(0.05)  # the twin rate-limits identical refusals to one per 50 ms
    return arm.errors.msg.data


def assert_still_publishing(twin, arm):
    """The refusals did not stall the tick: measured_js keeps coming (counted in ticks, not Hz)."""
    assert keeps_publishing(arm), "measured_js stopped"
    assert twin.alive(), twin.output()


def test_commands_while_disabled(client):
    twin, ral, arm = client
    assert arm.operating_state().state == "DISABLED"
    text = expect_error(arm, lambda: arm.servo_jp([0, 0, 0.1, 0, 0, 0]), "servo_jp", "DISABLED")
    assert "enable" in text
    expect_error(arm, lambda: arm.move_jp([0, 0, 0.1, 0, 0, 0]), "move_jp", "DISABLED")
    expect_error(arm, lambda: arm.jaw.move_jp(0.3), "jaw/move_jp", "DISABLED")
    T = arm.measured_cp()
    expect_error(arm, lambda: arm.servo_cp(T), "servo_cp", "DISABLED")
    assert_still_publishing(twin, arm)


def test_enable_without_home_still_refuses_motion(client):
    twin, ral, arm = client
    assert arm.enable(5)
    expect_error(arm, lambda: arm.servo_jp([0, 0, 0.1, 0, 0, 0]), "not homed")
    assert arm.home(10)


def test_unknown_state_command(client):
    twin, ral, arm = client
    expect_error(arm, lambda: arm._command("fly"), "unknown state command", "'fly'")
    assert arm.operating_state().state == "ENABLED"


def test_nan_and_inf(client):
    twin, ral, arm = client
    q = arm.measured_jp()
    bad = q.copy()
    bad[1] = math.nan
    expect_error(arm, lambda: arm.servo_jp(bad), "servo_jp refused", "position[1]", "nan")
    bad[1] = math.inf
    expect_error(arm, lambda: arm.move_jp(bad), "move_jp refused", "inf")
    expect_error(arm, lambda: arm.jaw.servo_jp(math.nan), "jaw/servo_jp refused", "nan")
    pose = arm.measured_cp()
    pose[0, 3] = math.nan
    expect_error(arm, lambda: arm.servo_cp(pose), "servo_cp refused", "not finite")
    np.testing.assert_allclose(arm.measured_jp(), q, atol=1e-9)  # nothing moved
    assert_still_publishing(twin, arm)


def test_wrong_length_and_names(client):
    twin, ral, arm = client
    q = arm.measured_jp()
    expect_error(arm, lambda: arm.servo_jp(q[:5]), "servo_jp refused", "5 position values, expected 6")
    expect_error(arm, lambda: arm.move_jp(list(q) + [0.0]), "move_jp refused", "7 position values")
    expect_error(arm, lambda: arm._servo_jp.publish(JointState()), "servo_jp refused", "empty")
    names = ["yaw", "pitch", "insertion", "roll", "wrist_pitch", "elbow"]
    expect_error(arm, lambda: arm._servo_jp.publish(JointState(name=names, position=[float(v) for v in q])),
                 "unknown joint name 'elbow'")
    # old (dVRK 2.2) names in another order are fine
    old = ["outer_pitch", "outer_yaw", "outer_insertion", "outer_roll", "outer_wrist_pitch", "outer_wrist_yaw"]
    target = q.copy()
    target[0] += 0.01
    before = arm.errors.count
    arm._servo_jp.publish(JointState(name=old, position=[float(target[i]) for i in (1, 0, 2, 3, 4, 5)]))
    assert arm.wait_measured(20, timeout=60)  # the command's tick and the 5 ms lag, in ticks
    assert arm.errors.count == before, arm.errors.msg.data
    np.testing.assert_allclose(arm.measured_jp(), target, atol=1e-6)
    assert_still_publishing(twin, arm)


def test_beyond_limits(client):
    twin, ral, arm = client
    q = arm.measured_jp()
    bad = q.copy()
    bad[2] = 0.3  # insertion limit is 0.24 m
    text = expect_error(arm, lambda: arm.move_jp(bad), "move_jp refused", "insertion", "beyond its limits")
    assert "0.24" in text
    bad = q.copy()
    bad[0] = 2.0
    expect_error(arm, lambda: arm.servo_jp(bad), "servo_jp refused", "yaw")
    # the dVRK clips jaw commands to the jaw's limits (a grasp commands past closed): not refused
    assert arm.jaw.move_jp(2.5).wait(10)
    assert abs(arm.jaw.measured_jp()[0] - 1.39626) < 0.01  # at the upper limit (measured lags 5 ms)
    np.testing.assert_allclose(arm.measured_jp(), q, atol=1e-9)
    assert_still_publishing(twin, arm)


def test_unreachable_cartesian(client):
    twin, ral, arm = client
    q = arm.measured_jp()
    far = arm.measured_cp()
    far[:3, 3] = (0.5, 0.5, -0.5)  # 0.87 m from the RCM: the tool reaches about 0.26 m
    expect_error(arm, lambda: arm.servo_cp(far), "servo_cp refused", "not reachable")
    expect_error(arm, lambda: arm.move_cp(far), "move_cp refused", "not reachable")
    msg = PoseStamped()
    msg.pose.orientation.w = 0.5  # not a unit quaternion
    expect_error(arm, lambda: arm._servo_cp.publish(msg), "servo_cp refused", "quaternion")
    np.testing.assert_allclose(arm.measured_jp(), q, atol=1e-9)
    assert_still_publishing(twin, arm)


def _refusal_totals(ral, after: float) -> dict:
    """{kind: refusals so far} from the first /diagnostics stamped after `after` (client clock)."""
    from diagnostic_msgs.msg import DiagnosticArray
    from cressim_ros.dvrk_client import PERIODIC, _Latest, stamp_s

    if not hasattr(ral, "diagnostics"):
        ral.diagnostics = _Latest()
        ral.subscriber(DiagnosticArray, "/diagnostics", ral.diagnostics, PERIODIC)
    assert ral.diagnostics.wait_for(lambda m: stamp_s(m.header) > after, 60), "no /diagnostics"
    return {kv.key[len("refused "):]: int(kv.value) for status in ral.diagnostics.msg.status
            for kv in status.values if kv.key.startswith("refused ")}


def test_a_warning_then_errors_keep_the_tick_and_are_counted_once(start_twin, ros_domain_id):
    """A twin's first refusal a warning (servo_jf), then error-level ones, in a callback (servo_jp
    beyond its limits, twice) and in the tick (a servo_cp whose batched IK fails there): each is
    published once, without a suffix of refusals that never were, and counted once in
    /diagnostics; the tick goes on and the twin reports no failure."""
    from cressim_ros.dvrk_client import Arm, Ral

    twin = start_twin(ros_domain_id)
    ral = Ral("severity_client", ros_domain_id)
    try:
        arm = Arm(ral, "/PSM1")
        servo_jf = ral.publisher(JointState, "/PSM1/servo_jf", arm._servo_jp.qos_profile)
        ral.check_connections(timeout=20)
        servo_jf.publish(JointState(effort=[0.0] * 6))
        assert arm.warnings.wait_for(lambda m: "servo_jf refused" in m.data, 10)
        assert arm.enable(10) and arm.home(30)
        bad = arm.measured_jp()
        bad[2] = 0.3  # insertion beyond 0.24 m
        texts = [expect_error(arm, lambda: arm.servo_jp(bad), "servo_jp refused", "insertion") for _ in range(2)]
        far = arm.measured_cp()
        far[:3, 3] = (0.5, 0.5, -0.5)
        texts.append(expect_error(arm, lambda: arm.servo_cp(far), "servo_cp refused", "not reachable"))
        assert_still_publishing(twin, arm)
        assert [m.data for m in arm.errors.history] == texts  # each published once
        assert not [t for t in texts if "similar" in t], texts
        counted = _refusal_totals(ral, time.time())
        assert counted == {"servo_jf": 1, "servo_jp": 2, "servo_cp": 1}, counted
    finally:
        ral.shutdown()
    output = twin.output()
    assert "tick failed" not in output and "severity" not in output, output[-3000:]


def test_stale_command(client):
    twin, ral, arm = client
    msg = JointState(position=[float(v) for v in arm.measured_jp()])
    msg.header.stamp.sec = int(time.time()) - 10
    expect_error(arm, lambda: arm._servo_jp.publish(msg), "servo_jp refused", "stale")


def test_unsupported_commands_warn(client):
    twin, ral, arm = client
    pub = ral.publisher(Empty, "/PSM1/free", arm._servo_jp.qos_profile)
    ral.check_connections(timeout=10)
    before = arm.warnings.count
    pub.publish(Empty())
    assert arm.warnings.wait_for(lambda m: arm.warnings.count > before and "kinematic" in m.data, 3)


def test_flood_of_bad_commands(client):
    """1,000 NaN commands as fast as they go: refusals are counted, published at a bounded rate,
    and measured_js keeps coming."""
    twin, ral, arm = client
    bad = [math.nan] * 6
    before = arm.errors.count
    t0 = time.monotonic()
    for _ in range(1000):
        arm.servo_jp(bad)
    assert arm.errors.wait_for(lambda m: arm.errors.count > before, 60)
    assert arm.wait_measured(20, timeout=60)  # the twin has taken what it was sent
    published = arm.errors.count - before
    # at most one refusal of a kind per 50 ms reaches `error`
    assert 1 <= published <= (time.monotonic() - t0) / 0.05 + 2, published
    assert_still_publishing(twin, arm)
    # a later good command still works
    q = arm.measured_jp()
    q[3] += 0.05
    assert arm.move_jp(q).wait(10)


def _set(ral, **values):
    cli = ral.node.create_client(SetParameters, "/cressim_twin/set_parameters")
    assert cli.wait_for_service(timeout_sec=10)
    params = []
    for name, value in values.items():
        v = ParameterValue()
        if isinstance(value, bool):
            v.type, v.bool_value = ParameterType.PARAMETER_BOOL, value
        elif isinstance(value, int):
            v.type, v.integer_value = ParameterType.PARAMETER_INTEGER, value
        elif isinstance(value, float):
            v.type, v.double_value = ParameterType.PARAMETER_DOUBLE, value
        elif isinstance(value, list):
            v.type, v.string_array_value = ParameterType.PARAMETER_STRING_ARRAY, value
        else:
            v.type, v.string_value = ParameterType.PARAMETER_STRING, value
        params.append(Parameter(name=name, value=v))
    future = cli.call_async(SetParameters.Request(parameters=params))
    deadline = time.monotonic() + 10
    while not future.done() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert future.done(), "set_parameters timed out"
    return future.result().results[0]


def test_parameters_validated_with_reasons(client):
    twin, ral, arm = client
    r = _set(ral, num_envs=4)
    assert not r.successful and "restart" in r.reason
    r = _set(ral, publish_rate=0.0)
    assert not r.successful and "publish_rate" in r.reason
    r = _set(ral, publish_rate=70.0)  # physics 200 Hz is not a multiple of 70
    assert not r.successful and "multiple" in r.reason
    r = _set(ral, sensors=["joints", "lidar"])
    assert not r.successful and "lidar" in r.reason
    r = _set(ral, record="/nonexistent/folder/bag")
    assert not r.successful and "does not exist" in r.reason
    r = _set(ral, tf_rate=25.0)
    assert r.successful, r.reason
    assert_still_publishing(twin, arm)
