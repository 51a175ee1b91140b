"""The twin's simulation control over DDS (simulation_interfaces services; a client node beside the
twin node on one executor's thread, as the twin's own main spins it, the twin's timer running):
pause, step, reset, stop, play, and the needle's pose set and read."""
import math

import numpy as np
import pytest

pytest.importorskip("simulation_interfaces.srv", reason="ros_ws's simulation_interfaces is not built")
pytestmark = pytest.mark.ros

from twin_fixtures import spinning  # noqa: E402


@pytest.fixture
def control(make_node):
    """(node, call): the twin node ticking on an executor's thread, and call(name, request) through
    a client node over DDS."""
    from simulation_interfaces import srv

    node = make_node(scene="psm_suture.yaml", sensors=["joints"])
    types = {"get_simulator_features": srv.GetSimulatorFeatures, "get_simulation_state": srv.GetSimulationState,
             "set_simulation_state": srv.SetSimulationState, "step_simulation": srv.StepSimulation,
             "reset_simulation": srv.ResetSimulation, "get_entities": srv.GetEntities,
             "get_entity_state": srv.GetEntityState, "set_entity_state": srv.SetEntityState}
    def call(name, **fields):
        client = clients[name]
        assert client.wait_for_service(timeout_sec=120), name
        request = types[name].Request()
        for k, v in fields.items():
            setattr(request, k, v)
        response = client.call(request, timeout_sec=120)
        assert response is not None, f"{name}: no response"
        return response

    with spinning(node, "sim_client") as client_node:
        clients = {name: client_node.create_client(t, f"/{name}") for name, t in types.items()}
        yield node, call


def _set(call, state):
    from simulation_interfaces.msg import SimulationState

    return call("set_simulation_state", state=SimulationState(state=state)).result


def test_pause_step_reset_stop_and_play(control):
    from simulation_interfaces.msg import Result, SimulationState, SimulatorFeatures

    node, call = control
    S, OK = SimulationState, Result.RESULT_OK
    features = call("get_simulator_features").features.features
    assert {SimulatorFeatures.STEP_SIMULATION_MULTIPLE, SimulatorFeatures.SIMULATION_STATE_PAUSE,
            SimulatorFeatures.ENTITY_STATE_SETTING} <= set(features)
    assert call("get_simulation_state").state.state == S.STATE_PLAYING
    while node.arms.sim_ns == 0:  # playing: the timer ticks
        call("get_simulation_state")
    assert call("step_simulation", steps=3).result.result == Result.RESULT_OPERATION_FAILED  # playing

    assert _set(call, S.STATE_PAUSED).result == OK
    assert _set(call, S.STATE_PAUSED).result == 101  # ALREADY_IN_TARGET_STATE
    node.arms.state_command(0, "enable")
    before = node.arms.sim_ns
    for _ in range(5):  # round trips through the executor that runs the timer: time stands still
        call("get_simulation_state")
    assert node.arms.sim_ns == before
    assert call("step_simulation", steps=7).result.result == OK
    assert node.arms.sim_ns == before + 7 * node.arms.period_ns  # exactly the steps asked for
    assert node.arms.report(0).state == "ENABLED"
    assert call("step_simulation", steps=0).result.result == Result.RESULT_OPERATION_FAILED

    node.arms.setpoint[0, 0] = 0.3  # the arm moved away from where it started
    assert call("reset_simulation", scope=1).result.result == OK  # SCOPE_TIME: the clock only
    assert node.arms.sim_ns == 0 and node.arms.report(0).state == "ENABLED"
    assert call("step_simulation", steps=2).result.result == OK
    assert call("reset_simulation", scope=0).result.result == OK  # SCOPE_DEFAULT: everything
    assert node.arms.sim_ns == 0 and node.arms.report(0).state == "DISABLED"
    assert float(node.arms.setpoint[0, 0]) == pytest.approx(node.scene.initial_jp[0])
    assert call("get_simulation_state").state.state == S.STATE_PAUSED  # a reset keeps the state

    assert call("step_simulation", steps=4).result.result == OK
    assert _set(call, S.STATE_STOPPED).result == OK  # stopped: reset and held
    assert node.arms.sim_ns == 0
    assert _set(call, S.STATE_QUITTING).result == Result.RESULT_FEATURE_UNSUPPORTED
    assert _set(call, S.STATE_PLAYING).result == OK
    while node.arms.sim_ns == 0:
        call("get_simulation_state")


def test_the_needle_is_an_entity_whose_pose_is_set_and_read(control):
    from geometry_msgs.msg import Pose
    from simulation_interfaces.msg import EntityFilters, EntityState, Result, SimulationState

    node, call = control
    assert sorted(call("get_entities").entities) == ["PSM1", "needle"]
    assert call("get_entities", filters=EntityFilters(filter="^nee")).entities == ["needle"]
    assert _set(call, SimulationState.STATE_PAUSED).result == Result.RESULT_OK
    got = call("get_entity_state", entity="needle")
    assert got.result.result == Result.RESULT_OK and got.state.header.frame_id == "world"
    p = got.state.pose.position
    np.testing.assert_allclose([p.x, p.y, p.z], node.arms.instrument("needle").pose(node.arms, 0)[:3, 3], atol=1e-6)

    # 3 cm to the side and turned a quarter about z, out of the jaws
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = p.x + 0.03, p.y, p.z
    pose.orientation.z = pose.orientation.w = math.sqrt(0.5)
    r = call("set_entity_state", entity="needle", state=EntityState(pose=pose), set_pose=True)
    assert r.result.result == Result.RESULT_OK, r.result.error_message
    assert call("step_simulation", steps=3).result.result == Result.RESULT_OK
    T = node.arms.instrument("needle").pose(node.arms, 0)
    # let go of at rest there, it falls freely: g t^2 / 2 and semi-implicit Euler's g t h / 2 (h the substep)
    t = 3 * node.arms.bodies.dt
    h = node.arms.bodies.dt / node.arms.bodies.engine.physics.substeps
    np.testing.assert_allclose(T[:2, 3], [p.x + 0.03, p.y], atol=1e-6)
    assert p.z - T[2, 3] == pytest.approx(9.81 * t * (t + h) / 2, rel=0.02)
    np.testing.assert_allclose(T[:3, 0], [0, 1, 0], atol=1e-5)
    assert not node.arms.instrument("needle").held[0]
    back = call("get_entity_state", entity="needle").state.pose.orientation
    assert abs(back.z) == pytest.approx(math.sqrt(0.5), abs=1e-5)

    bad = Pose()
    bad.orientation.w = 2.0
    r = call("set_entity_state", entity="needle", state=EntityState(pose=bad), set_pose=True)
    assert r.result.result == 101 and "unit quaternion" in r.result.error_message  # INVALID_POSE
    r = call("set_entity_state", entity="PSM1", state=EntityState(pose=pose), set_pose=True)
    assert r.result.result == Result.RESULT_OPERATION_FAILED and "base" in r.result.error_message
    r = call("get_entity_state", entity="nothing")
    assert r.result.result == Result.RESULT_NOT_FOUND and "needle" in r.result.error_message
