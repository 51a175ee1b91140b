"""The dynamic arm (`dynamics: dynamic`), FAULT on the engine's health flags, the per-link
entity ids for segmentation, and the in-process step hooks. The arms (cressim.twin.TwinArms, no
ROS) are ticked by hand (docs/twin.md, "Dynamic arm", "Faults", "Training beside the twin").

Tolerances stated here (docs/twin.md repeats them): after a move_jp's trajectory ends, measured
reaches the goal within 1e-3 rad on the hinges and 1e-4 m on the insertion within 1 s of
simulated time; the jaw within 1e-3 rad; while moving, measured lags the setpoint by more than
1e-3 rad somewhere (it is simulated, not copied); measured stays inside the joint limits
(1e-3 of slack); a drive pushed beyond a limit is held by the engine's limit within 0.01 rad
(1 mm on the insertion); setpoints beyond the limits are clamped (and ramped) by the twin and
measured stays within 0.03 rad of the limits (the light wrist overshoots a little when it
reaches a limit at full speed).
"""
import numpy as np
import pytest
import torch

from cressim.twin import JointCommand

LOWER = np.array([-1.588, -0.925025, 0.0, -4.53786, -1.39626, -1.39626])
UPPER = np.array([1.588, 0.925025, 0.24, 4.53786, 1.39626, 1.39626])
REVOLUTE = np.array([True, True, False, True, True, True])


def _state_command(arms, env, command, events):
    events += arms.state_command(env, command)


def _tick(arms, events):
    events += arms.tick()


def _ready(arms, envs, events):
    for env in envs:
        _state_command(arms, env, "enable", events)
        _state_command(arms, env, "home", events)
    for _ in range(5):
        _tick(arms, events)
    while not all(arms.states[env].is_homed for env in envs):
        _tick(arms, events)


def _move_and_settle(arms, env, goal, events, *, max_ticks=400):
    """move_jp to goal; returns (max |measured - setpoint| while moving, settle ticks after the
    goal_reached event or None, worst limit excess seen)."""
    events += arms.move_jp(env, JointCommand(position=goal))
    lag, excess, reached_at, settled_at = 0.0, 0.0, None, None
    goal_t = torch.as_tensor(goal, dtype=torch.float64)
    for tick in range(max_ticks):
        _tick(arms, events)
        m = arms.measured[env].cpu().numpy()
        excess = max(excess, float(np.max(np.maximum(LOWER - m, m - UPPER))))
        if reached_at is None:
            lag = max(lag, float((arms.measured[env] - arms.setpoint[env]).abs().max()))
            if any(e == env and name == "goal_reached" and value for e, name, value in events):
                reached_at = tick
        else:
            err = (arms.measured[env].cpu() - goal_t).abs().numpy()
            if (err[REVOLUTE] < 1e-3).all() and err[2] < 1e-4:
                settled_at = tick - reached_at
                break
            if tick - reached_at > 100:  # 1 s of simulated time
                break
    return lag, settled_at, excess


@pytest.mark.parametrize("robot", ["psm_lnd", "psm_suction"])
def test_dynamic_move_jp_reaches_goal(make_arms, robot):
    arms = make_arms(dynamics="dynamic", robot=robot)
    events = []
    _ready(arms, [0], events)
    goal = [0.6, -0.4, 0.18, 1.2, 0.5, -0.4] if robot == "psm_lnd" else [0.6, -0.4, 0.18, 1.2, 0.0, 0.0]
    lag, settled, excess = _move_and_settle(arms, 0, goal, events)
    assert lag > 1e-3, f"measured followed the setpoint exactly ({lag}): not simulated?"
    assert settled is not None, f"not within 1e-3 rad / 1e-4 m of the goal 1 s after the trajectory: " \
                                f"{(arms.measured[0].cpu() - torch.tensor(goal, dtype=torch.float64)).numpy()}"
    assert excess < 1e-3, f"measured left the joint limits by {excess}"
    # measured is the engine's joint coordinates, gathered by index (the roll unwrapped)
    dof = arms.psm.dof
    raw = arms.bodies.joint_positions[arms.bodies.joint_rows[0, :dof]].double().cpu()
    turn = (arms.measured[0, :dof].cpu() - raw + np.pi) % (2 * np.pi) - np.pi
    assert turn.abs().max() < 1e-5
    # measured_cp is FK of measured
    T = arms.kin.forward(arms.measured[:1])[0]
    assert torch.allclose(T, arms.kin.forward(torch.tensor([goal], dtype=torch.float64))[0], atol=2e-3)

    if robot == "psm_lnd":
        events += arms.jaw_move_jp(0, JointCommand(position=[0.8]))
        for _ in range(150):
            _tick(arms, events)
        assert abs(float(arms.jaw_meas[0, 0]) - 0.8) < 1e-3
    assert not [value for _, name, value in events if name == "error"]


def test_dynamic_joint_limits_hold(make_arms):
    """Drive targets written beyond the limits of yaw, pitch and insertion (past the twin's own
    clamping) stop at the engine's limits; setpoints beyond every limit (an in-process driver)
    are clamped by the twin. The engine does not hold a light wrist joint whose drive target is
    beyond its limit (docs/twin.md): the twin never writes such a target."""
    arms = make_arms(dynamics="dynamic")
    events = []
    _ready(arms, [0], events)
    bodies = arms.bodies
    beyond = torch.tensor([1.8, 1.2, 0.35], dtype=torch.float64)
    rows = bodies.joint_rows[0, :3]
    set_targets = bodies.set_targets

    def pushed(*args, **kwargs):
        set_targets(*args, **kwargs)
        bodies.joint_targets[rows, 0] = beyond.to(bodies.joint_targets)

    bodies.set_targets = pushed
    worst = 0.0
    for _ in range(120):
        _tick(arms, events)
        m = arms.measured[0].cpu().numpy()
        worst = max(worst, float(np.max(m[:2] - UPPER[:2])), float(m[2] - 0.24) * 10)
    assert worst < 0.01, f"a joint left its limit by {worst} (insertion x 10)"
    m = arms.measured[0].cpu().numpy()
    assert m[2] > 0.235 and m[0] > 1.55 and m[1] > 0.9, m  # pushed against the limits

    bodies.set_targets = set_targets
    outside = torch.tensor([-2.0, -1.2, -0.1, -5.0, -1.7, 1.7], dtype=torch.float64)
    arms.step_hooks.append(lambda n: n.setpoint.__setitem__(0, outside))
    worst = 0.0
    for _ in range(200):  # the setpoint is clamped and ramped at the velocity limits (yaw: 2 rad/s)
        _tick(arms, events)
        m = arms.measured[0].cpu().numpy()
        worst = max(worst, float(np.max(np.maximum(LOWER - m, m - UPPER))))
    assert worst < 0.03, f"a joint left its limit by {worst}"
    assert np.abs(arms.measured[0].cpu().numpy() - np.clip(outside.numpy(), LOWER, UPPER)).max() < 0.01


def test_fault_on_health_flag_and_recovery(make_arms):
    arms = make_arms(dynamics="dynamic", num_envs=2)
    events = []
    _ready(arms, [0, 1], events)
    events += arms.move_jp(0, JointCommand(position=[0.3, 0.2, 0.12, 0.0, 0.0, 0.0]))
    for _ in range(3):
        _tick(arms, events)
    # provoke: env 0's next reset spins the yaw at 1e5 rad/s, far beyond the solver's max_speed
    bodies = arms.bodies
    bodies.joint_reset[int(bodies.joint_rows[0, 0]), 1] = 1e5
    bodies.engine.reset_envs([0])
    _tick(arms, events)
    assert arms.states[0].state == "FAULT" and arms.states[1].state == "ENABLED"
    errors = [(env, value) for env, name, value in events if name == "error"]
    assert len(errors) == 1 and errors[0][0] == 0, errors
    assert "max_speed" in errors[0][1] and "env.health = 2" in errors[0][1] and "enable" in errors[0][1]
    states = [value for env, name, value in events if env == 0 and name == "operating_state"]
    assert states[-1].state == "FAULT" and not states[-1].is_busy
    assert any(env == 0 and name == "goal_reached" and not value for env, name, value in events)
    assert torch.isfinite(arms.measured).all()

    refused = arms.move_jp(0, JointCommand(position=[0.0, 0.0, 0.1, 0.0, 0.0, 0.0]))
    assert refused and refused[0].topic == "error" and "FAULT" in refused[0].value

    for _ in range(20):  # the engine reset env 0 at the next frame: back at its setpoint, healthy
        _tick(arms, events)
    assert arms.states[0].state == "FAULT"  # until enable
    assert int(bodies.health_flags()[0]) == 0
    assert (arms.measured[0] - arms.setpoint[0]).abs().max() < 1e-2
    _state_command(arms, 0, "enable", events)
    assert arms.states[0].state == "ENABLED" and arms.states[0].is_homed
    events.clear()
    lag, settled, _ = _move_and_settle(arms, 0, [0.0, 0.0, 0.1, 0.0, 0.0, 0.0], events)
    assert settled is not None and arms.states[0].state == "ENABLED"
    assert not [value for _, name, value in events if name == "error"]


@pytest.mark.parametrize("dynamics", ["kinematic", "dynamic"])
def test_link_entity_ids_for_segmentation(make_arms, dynamics):
    arms = make_arms(dynamics=dynamics, num_envs=2)
    bodies = arms.bodies
    ids = bodies.link_entity_ids
    assert ids.shape == (2, len(bodies.link_names)) and "PSM1_shaft_link" in bodies.link_names
    world = bodies.engine.world
    for env in range(2):
        for link, entity in zip(bodies.link_names, ids[env]):
            e = world.entity(int(entity))
            assert e.name == link and e.env == env
    assert len(set(ids.reshape(-1).tolist())) == ids.size  # one entity per link and env (lnd)


def test_suction_tube_shares_the_shaft_entity(make_arms):
    bodies = make_arms(dynamics="dynamic", robot="psm_suction").bodies
    ids = dict(zip(bodies.link_names, bodies.link_entity_ids[0]))
    assert ids["PSM1_suction_tube_link"] == ids["PSM1_shaft_link"]
    assert bodies.joint_names == ["yaw", "pitch", "insertion", "roll"]


def test_step_hook_drives_other_envs(make_arms):
    """ROS's env 0 untouched while a hook (a training loop in this process) drives env 1."""
    arms = make_arms(dynamics="dynamic", num_envs=2)
    events = []
    target = torch.tensor([0.2, -0.1, 0.14, 0.5, 0.2, 0.1], dtype=torch.float64)
    arms.step_hooks.append(lambda n: n.setpoint.__setitem__(1, target))
    for _ in range(120):
        _tick(arms, events)
    assert (arms.measured[1] - target).abs().max() < 2e-3
    assert (arms.measured[0] - arms.setpoint[0]).abs().max() < 1e-3
    arms.reset_envs([1], torch.zeros(1, 6, dtype=torch.float64) + torch.tensor([0, 0, 0.1, 0, 0, 0]))
    arms.step_hooks.clear()
    _tick(arms, events)
    assert (arms.measured[1] - torch.tensor([0, 0, 0.1, 0, 0, 0], dtype=torch.float64)).abs().max() < 2e-3
