"""The twin over tissue (scenes/psm_retraction.yaml: a flap whose far edge is held to the table),
without ROS: the needle driver's jaws close on the flap's free edge and hold it while the arm
lifts, the tool feels the flap (measured_cf), opening lets go, and an env whose jaws stay open
takes nothing. Two envs, batched."""
import numpy as np
import pytest
import torch

from cressim.twin import JointCommand
from cressim.twin_scene_file import SceneError, load_scene, parse_scene

from arm_moves import EDGE, jaws_at, run_ticks, settle

LIFT = 0.02


@pytest.mark.parametrize("dynamics", ["kinematic", "dynamic"])
def test_the_jaws_grasp_lift_and_release_the_flap(make_arms, dynamics):
    """With the kinematic arm (links posed by FK) and the dynamic one (jointed bodies that bear the
    flap they hold; at 800 Hz, as docs/twin.md says a dynamic arm holding tissue needs, with the
    flap's particles at 200 Hz)."""
    scene = load_scene("psm_retraction.yaml")
    scene.dynamics = dynamics
    if dynamics == "dynamic":
        scene.physics_rate, scene.particle_rate = 800.0, 200.0
    arms = make_arms(scene=scene, num_envs=2)
    assert arms.simulated and arms.instrument("jaws") is not None
    for env in range(2):
        arms.state_command(env, "enable")
        arms.state_command(env, "home")
    settle(arms)
    positions = arms.bodies.engine.buffer("particles.positions")
    flat = positions.read()[:, :3].reshape(2, -1, 3).copy()
    jaws_at(arms, 0.02, jaws=[0.8, 0.8])
    jaws_at(arms, 0.0)
    before = positions.read()[:, :3].reshape(2, -1, 3).copy()
    arms.jaw_move_jp(0, JointCommand(position=[-0.2]))  # env 0 closes; env 1's jaws stay open
    settle(arms)
    held = arms.instrument("jaws").grasp.held()
    assert held[0] > 0 and held[1] == 0
    jaws_at(arms, LIFT)
    run_ticks(arms, 100)  # one second held up
    x = positions.read()[:, :3].reshape(2, -1, 3)
    slots = arms.bodies.engine.buffer("control.particle_attachments").read()
    taken = slots[:held[0], 0].astype(np.int64)  # env 0: its slots come first, its particles too
    np.testing.assert_allclose(x[0, taken, 2] - before[0, taken, 2], LIFT, atol=1e-3)
    flap = np.arange(len(flat[0])) < int(arms.bodies.engine.particle_mapping["object_count"][0])  # then the suture
    free_edge = flap & (flat[0, :, 1] < flat[0, flap, 1].min() + 1e-4)
    assert (x[0, free_edge, 2] - flat[0, free_edge, 2]).mean() > 0.5 * LIFT  # the edge comes up with the jaws
    assert abs(x[1] - flat[1]).max() < 2e-3  # open jaws passed the edge without taking it
    snap = arms.snapshot()
    force = snap.spatial_cf[0, :3]
    weight = 1000.0 * 0.06 * 0.04 * 0.006 * 9.81
    # the flap's weight and its tension towards the held edge (+y) pull the tool down and back
    assert force[2] < -0.2 * weight and force[1] > 0.05 * weight, force
    assert abs(np.linalg.norm(snap.body_cf[0, :3]) - np.linalg.norm(force)) < 1e-9  # the same force, tip axes
    assert np.abs(snap.spatial_cf[1]).max() < 1e-6  # nothing on env 1's tool
    if dynamics == "dynamic":  # the insertion drive bears the flap: its integral term takes the load
        run_ticks(arms, 100)
        J, _ = arms.kin.jacobian(arms.measured[:1])
        load = (J[0].T @ torch.as_tensor(arms.snapshot().spatial_cf[0]))[2].item()  # N along the shaft
        bias = arms.bodies._bias[:, 2] * arms.bodies.stiffness[2]  # what env 1's idle arm also has
        assert abs(load) > 0.1 and abs((bias[1] - bias[0]).item() - load) < 0.15 * abs(load), (load, bias)
    arms.jaw_move_jp(0, JointCommand(position=[0.8]))
    settle(arms)
    run_ticks(arms, 100)
    assert arms.instrument("jaws").grasp.held()[0] == 0
    back = positions.read()[:, :3].reshape(2, -1, 3)
    np.testing.assert_allclose(back[0, free_edge, 2], flat[0, free_edge, 2], atol=1.5e-3)


@pytest.mark.parametrize("dynamics", ["kinematic", "dynamic"])
def test_the_arm_presses_the_flap_and_feels_it(make_arms, dynamics):
    """Closed jaws pressed 3 mm into the middle of the flap dent it and the tool feels the tissue
    (spatial/measured_cf), with the kinematic arm (links posed by FK) and with the dynamic one
    (jointed bodies that the particles push back); env 1's jaws, 10 mm above, feel nothing."""
    scene = load_scene("psm_retraction.yaml")
    scene.dynamics = dynamics
    arms = make_arms(scene=scene, num_envs=2)
    for env in range(2):
        arms.state_command(env, "enable")
        arms.state_command(env, "home")
    settle(arms)
    middle = np.array([0.0, 0.0, 0.1575])  # the flap's top at its centre
    positions = arms.bodies.engine.buffer("particles.positions")
    jaws_at(arms, 0.01, jaws=[0.0, 0.0], point=middle)
    flat = positions.read()[:, :3].reshape(2, -1, 3).copy()
    jaws_at(arms, [-0.003, 0.01], point=middle)
    run_ticks(arms, 20)
    dent = (flat - positions.read()[:, :3].reshape(2, -1, 3))[:, :, 2].max(axis=1)
    force = arms.snapshot().spatial_cf[:, :3]
    assert dent[0] > 5e-5 and dent[1] < 1e-5, dent
    assert np.linalg.norm(force[0]) > 0.005 and np.abs(force[1]).max() < 1e-6, force


def test_a_missing_world_file_names_its_line(tmp_path):
    with pytest.raises(SceneError, match=r"twin.yaml:2:8: world: no scene file 'nowhere.yaml'"):
        parse_scene("num_envs: 1\nworld: nowhere.yaml\n", str(tmp_path / "twin.yaml"))


def test_suction_fields_are_read_and_checked(tmp_path):
    scene = load_scene("psm_suction.yaml")
    assert (scene.suction_radius, scene.suction_flow_rate, scene.suction_reach) == (0.005, 1.667e-5, 0.02)
    with pytest.raises(SceneError, match=r"twin.yaml:4:12: arm.suction.reach: 0.002 m is less than the radius 0.005 m"):
        parse_scene("arm:\n  suction:\n    radius: 0.005\n    reach: 0.002\n", str(tmp_path / "twin.yaml"))
    with pytest.raises(SceneError, match=r"twin.yaml:3:16: arm.suction.flow_rate: -1 is outside \[0, 0.001\]"):
        parse_scene("arm:\n  suction:\n    flow_rate: -1\n", str(tmp_path / "twin.yaml"))


def _active_fluid(engine):
    phases = engine.buffer("particles.phases").read()
    return (phases[:, 0] == 2) & (phases[:, 3] & 1 != 0)


def test_the_suction_tool_removes_blood_at_its_tip(make_arms):
    """psm_suction over blood_suction.yaml's pool: shut, nothing goes; open, the blood within the
    radius of the tube's end goes (counted on suction/measured_js's effort), nothing farther."""
    arms = make_arms(scene=load_scene("psm_suction.yaml"))
    assert arms.instrument("suction") is not None and arms.instrument("jaws") is None
    assert [e.value for e in arms.instrument_command(0, "suction/servo_jp", JointCommand(position=[1.0])) if e.topic == "error"]  # disabled
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    settle(arms)
    arms.move_jp(0, JointCommand(position=[0.0, 0.0, 0.1385, 0.0, 0.0, 0.0]))  # the tube's end in the pool
    settle(arms)
    run_ticks(arms, 30)
    engine = arms.bodies.engine
    tip = (arms.bodies.base @ arms.kin.forward(arms.measured))[0, :3, 3].numpy()
    before = _active_fluid(engine)
    x = engine.buffer("particles.positions").read()[:, :3]
    near = before & (np.linalg.norm(x - tip, axis=1) < arms.scene.suction_radius)
    assert near.sum() > 0, "the tip is in the pool"
    refused = arms.instrument_command(0, "suction/servo_jp", JointCommand(position=[2.0]))
    assert [e.value for e in refused if e.topic == "error"], "a valve opening past 1 is refused"
    assert not arms.instrument_command(0, "suction/servo_jp", JointCommand(position=[1.0], name=["suction"]))
    run_ticks(arms, 1)  # flagged and removed in the tick's step (its freed slots may bleed in again at the vessel)
    after = _active_fluid(engine)
    y = engine.buffer("particles.positions").read()[:, :3]
    r = arms.scene.suction_radius
    inner = before & (np.linalg.norm(x - tip, axis=1) < r - 0.002)  # within reach however they moved in the tick
    outer = before & (np.linalg.norm(x - tip, axis=1) > r + 0.002)
    assert inner.any() and not (after & inner & (np.linalg.norm(y - tip, axis=1) < r)).any()  # those went
    assert after[outer].all()  # the rest of the pool stays
    assert arms.snapshot().suction_removed[0, 0] >= inner.sum()
    arms.instrument_command(0, "suction/servo_jp", JointCommand(position=[0.0]))
    run_ticks(arms, 1)
    count = arms.instrument("suction").suction.removed()[0]
    run_ticks(arms, 10)
    assert arms.instrument("suction").suction.removed()[0] == count  # shut: nothing more goes


def test_the_needle_driver_has_no_suction(make_arms):
    arms = make_arms(scene=load_scene("psm_retraction.yaml"))
    refused = arms.instrument_command(0, "suction/servo_jp", JointCommand(position=[1.0]))
    assert "has no suction tube" in [e.value for e in refused if e.topic == "error"][0]


def test_the_twin_images_the_phantom_with_the_world_probe(make_arms):
    """psm_ultrasound.yaml: the world file's probe is the twin's (its pose goes on /tf_static);
    its image shows the gel's speckle and the cyst's dark."""
    arms = make_arms(scene=load_scene("psm_ultrasound.yaml"), ultrasound=True)
    scenery = arms.bodies.scenery
    assert scenery.ultrasound is not None
    position, rotation = scenery.probe_pose()
    np.testing.assert_allclose(position, (0.0, 0.0, 0.182), atol=1e-6)  # ultrasound_phantom.yaml's probe
    assert "phantom" in scenery.labels.values()
    run_ticks(arms, 5)
    with arms.engine_lock:
        arms.step_engine(sense=True)
    image = arms.bodies.engine.buffer("ultrasound0.image").read()[0]
    assert image.mean() > 0.1 and (image < 0.02).mean() > 0.005


def test_the_jaws_pick_up_the_suture(make_arms):
    """tissue_retraction.yaml's thread lies on the table beside the flap: the jaws close on its
    middle and lift it 20 mm; the thread's held particles follow and its ends hang below."""
    arms = make_arms(scene=load_scene("psm_retraction.yaml"))
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    settle(arms)
    first = int(arms.bodies.engine.particle_mapping["object_count"][0])  # the flap's particles come first
    x0 = arms.bodies.engine.buffer("particles.positions").read()[:, :3].copy()
    thread = slice(first, len(x0))
    middle = x0[thread][len(x0[thread]) // 2].astype(np.float64)
    jaws_at(arms, 0.02, jaws=[0.8], point=middle)
    jaws_at(arms, 0.0, point=middle)
    arms.jaw_move_jp(0, JointCommand(position=[-0.2]))
    settle(arms)
    held = arms.instrument("jaws").grasp.held()[0]
    taken = arms.bodies.engine.buffer("control.particle_attachments").read()[:held, 0].astype(np.int64)
    assert held > 0 and (taken >= first).all()  # thread particles only
    jaws_at(arms, LIFT, point=middle)
    run_ticks(arms, 60)
    x = arms.bodies.engine.buffer("particles.positions").read()[:, :3]
    np.testing.assert_allclose(x[taken, 2] - x0[taken, 2], LIFT, atol=2e-3)
    assert x[thread][[0, -1], 2].max() < x[taken, 2].min()  # the ends hang lower than where it is held
