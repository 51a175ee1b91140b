"""The patient cart without ROS (cressim.twin.Cart): several arms in one engine where the scene
file's setup joints put them, and the ECM's stereo endoscope, whose disparity gives depth."""
import numpy as np
import pytest
import torch

from cressim.robots.ecm import ecm_forward_kinematics
from cressim.robots.kinematics import pose7_to_matrix
from cressim.twin import TwinConfig, load_scene, parse_scene
from cressim.twin.cart import Cart, pairs
from cressim.twin_scene_file import SceneError

ECM_Q = (0.08, 0.12, 0.06, 0.2)  # a pose off every axis: the eyes must follow the ECM's tip
ECM_BASE = (0.0, 0.0, 0.33)
BASELINE = 0.005


@pytest.fixture
def make_cart():
    made = []

    def make(scene, **config):
        cart = Cart(TwinConfig(scene=scene, **{"camera_width": 64, "camera_height": 48, **config}))
        made.append(cart)
        return cart

    yield make
    for cart in made:  # tests/conftest.py turns the Vulkan validation layer on
        assert cart.engine.validation_messages == [], "\n".join(cart.engine.validation_messages)


def _body_positions(cart, bodies, link):
    k = bodies.body_names.index(link)
    rows = bodies.body_rows[0, k]
    return torch.from_dlpack(cart.engine.buffer("rigid.positions"))[rows, :3].double().cpu().numpy()


def test_arms_share_one_engine_at_their_setup_joint_bases(make_cart):
    cart = make_cart(load_scene("patient_cart.yaml"))
    assert cart.names == ["PSM1", "PSM2"] and cart.ecm.name == "ECM"
    assert all(arm.bodies.engine is cart.engine for arm in cart.psms)
    q = torch.tensor([[0.2, -0.1, 0.12, 0.3, 0.1, -0.2]], dtype=torch.float64)
    for arm in cart.psms:  # the same joints, each tip where its own base puts it
        arm.setpoint[:] = q
        arm.measured[:] = q
    with cart.engine_lock:
        cart.step_engine()
    tips = []
    for arm, base in zip(cart.psms, cart.psm_bases):
        expected = (base @ arm.kin.forward(q)[0].numpy())[:3, 3]
        got = _body_positions(cart, arm.bodies, "PSM1_wrist_yaw_link")  # the jaw pivot: the tip's origin
        assert np.allclose(got, expected, atol=2e-5), (arm.arm, got, expected)
        tips.append(got)
    assert np.linalg.norm(tips[0] - tips[1]) > 0.03  # two arms, not one drawn twice
    # the eyes ride on the ECM's tip, baseline apart along its x
    cart.ecm.measured[0] = torch.as_tensor(ECM_Q)
    with cart.engine_lock:
        cart.step_engine()
    tip = cart.ecm_base @ ecm_forward_kinematics(np.array(ECM_Q))
    eyes = torch.from_dlpack(cart.engine.buffer("rigid.positions"))[cart._camera_rows, :3].double().cpu().numpy()
    assert np.allclose(eyes.mean(0), tip[:3, 3], atol=2e-5)
    assert np.allclose(eyes[1] - eyes[0], BASELINE * tip[:3, 0], atol=2e-6)


def test_stereo_disparity_gives_depth(make_cart, tmp_path):
    """A 3 mm bead in front of the endoscope: the horizontal offset of its image between the left
    and right eye (rows match: the pair is rectified) gives its depth Z = fx B / d within 1 %."""
    tip = pose7_to_matrix(np.array([*ECM_BASE, 0, 0, 0, 1])) @ ecm_forward_kinematics(np.array(ECM_Q))
    bead = (tip @ np.array([0.006, -0.004, 0.07, 1.0]))[:3]  # 7 cm in front of the scope, off centre
    world = tmp_path / "bead.yaml"
    world.write_text(
        "entities:\n"
        f"  - name: bead\n    transform: {{position: [{bead[0]:.9f}, {bead[1]:.9f}, {bead[2]:.9f}]}}\n"
        "    renderable: {mesh: {sphere: {radius: 0.003}}, color: [0.9, 0.9, 0.9, 1], segmentation_id: 1}\n")
    scene = parse_scene(
        "cart:\n"
        f"  ECM: {{base: {{position: {list(ECM_BASE)}}}, initial_jp: {list(ECM_Q)},"
        f" endoscope: {{baseline: {BASELINE}}}}}\n"
        "  PSM1: {base: {position: [0.0, -0.035, 0.30]}}\n"
        f"world: {world}\n", str(tmp_path / "cart.yaml"))
    cart = make_cart(scene, camera_width=640, camera_height=480)
    with cart.engine_lock:
        cart.step_engine(render=True)
    images = cart.images(["segmentation", "depth"])
    labels = {v: k for k, v in cart.scenery.labels.items()}
    centres = []
    for seg in images["segmentation"]:
        ys, xs = np.nonzero(seg == labels["bead"])
        assert xs.size > 100, "the bead is in both eyes' view"
        centres.append((xs.mean(), ys.mean()))
    (xl, yl), (xr, yr) = centres
    assert abs(yl - yr) < 0.05  # rectified: the same row
    fx = cart.scenery.camera.intrinsics()[0]
    disparity = xl - xr
    left = cart.eye_poses()[0]
    depth = (np.linalg.solve(left, np.append(bead, 1.0)))[2]  # the bead's centre along the left optical axis
    assert disparity > 0
    assert abs(fx * BASELINE / disparity - depth) < 0.01 * depth, (fx * BASELINE / disparity, depth)
    # the depth image agrees (its nearest surface is the bead's front, a radius nearer)
    row, col = int(round(yl)), int(round(xl))
    assert abs(images["depth"][0][row, col] - (depth - 0.003)) < 0.001


def test_cart_scene_errors_name_the_field():
    with pytest.raises(SceneError, match=r"cart.yaml:2:.*cart.PSM1.initial_jp: expected 6 numbers"):
        parse_scene("cart:\n  PSM1: {initial_jp: [0, 0]}\n  ECM: {}\n", "cart.yaml")
    with pytest.raises(SceneError, match=r"cart.yaml:2:.*cart: a cart needs the ECM"):
        parse_scene("cart:\n  PSM1: {}\n", "cart.yaml")
    with pytest.raises(SceneError, match=r"cart.PSM4: unknown field"):
        parse_scene("cart:\n  PSM4: {}\n", "cart.yaml")


def test_setup_joints_place_the_bases():
    """cart.PSM1.setup_joints: the dVRK Classic SUJ's kinematics from the cart's origin; the column
    (the SUJ's prismatic first joint) lifts the base straight up by its travel."""
    from cressim.robots.suj import SUJ_SIMULATED, suj_base

    q = np.array(SUJ_SIMULATED["PSM1"])
    scene = parse_scene("cart:\n  origin: {position: [0.1, -1.0, -0.5]}\n  ECM: {}\n"
                        f"  PSM1: {{setup_joints: {q.tolist()}}}\n", "cart.yaml")
    psm1 = next(a for a in scene.cart if a.name == "PSM1")
    expected = suj_base("PSM1", q)
    assert np.allclose(psm1.base_position, expected[:3, 3] + [0.1, -1.0, -0.5], atol=1e-12)
    assert np.allclose(pose7_to_matrix(np.array([*psm1.base_position, *psm1.base_rotation]))[:3, :3], expected[:3, :3],
                       atol=1e-9)
    lifted = suj_base("PSM1", q + [0.05, 0, 0, 0, 0, 0])
    assert np.allclose(lifted[:3, 3] - expected[:3, 3], [0, 0, 0.05], atol=1e-12)
    assert np.allclose(lifted[:3, :3], expected[:3, :3], atol=1e-12)
    with pytest.raises(SceneError, match=r"cart.PSM1.setup_joints: give either base or setup_joints"):
        parse_scene("cart:\n  ECM: {}\n  PSM1: {base: {}, setup_joints: [0, 0, 0, 0, 0, 0]}\n", "cart.yaml")
    with pytest.raises(ValueError, match="no setup joints for 'PSM4'"):
        suj_base("PSM4", q)


def test_scripted_operator_drives_the_mtm_in_the_tick(make_cart):
    """cart.operator's keyframes (simulated time) move MTMR's grip and press the clutch."""
    scene = parse_scene(
        "cart:\n  ECM: {}\n  PSM1: {}\n  MTMR: {}\n  operator:\n"
        "    - {at: 0.1, present: true, MTMR: {position: [0, 0, 0], gripper: 0.2}}\n"
        "    - {at: 0.3, clutch: true, MTMR: {position: [0.02, -0.01, 0.0], gripper: 0.6}}\n", "cart.yaml")
    cart = make_cart(scene)
    mtm = cart.mtms[0]
    while cart.sim_ns < 200_000_000:  # half way between the keyframes
        cart.tick()
    assert np.allclose(mtm.pose[:3, 3], [0.01, -0.005, 0.0], atol=1e-3) and mtm.gripper == pytest.approx(0.4, abs=0.03)
    assert cart.operator.pedals() == {"clutch": False, "camera": False, "operator_present": True}
    while cart.sim_ns < 400_000_000:
        cart.tick()
    assert np.allclose(mtm.pose[:3, 3], [0.02, -0.01, 0.0]) and mtm.gripper == pytest.approx(0.6)
    assert cart.operator.clutch


def test_instruments_that_touch_are_reported(make_cart):
    """PSM2's jaws driven onto PSM1's shaft: a warning on both arms when they touch, a status when
    they part (the kinematic arms pass through each other in the engine)."""
    from cressim.robots.dvrk_dh import dh_forward_kinematics

    cart = make_cart(load_scene("patient_cart.yaml"))
    home = torch.tensor([[0.0, 0.0, 0.12, 0.0, 0.0, 0.0]], dtype=torch.float64)
    for arm in cart.psms:
        arm.setpoint[:], arm.measured[:] = home, home
    assert [e for e in cart.tick() if e.topic == "warning"] == []
    F = cart.psm_bases[0] @ dh_forward_kinematics(home[0].numpy(), all_frames=True)
    on_shaft = F[3, :3, 3] + 0.02 * (F[2, :3, 3] - F[3, :3, 3]) / np.linalg.norm(F[2, :3, 3] - F[3, :3, 3])
    psm2 = cart.psms[1]
    T = psm2.kin.forward(home)[0].numpy()
    T[:3, 3] = np.linalg.solve(cart.psm_bases[1], np.append(on_shaft, 1.0))[:3]  # its jaw pivot there
    q, ok = psm2.kin.inverse(torch.as_tensor(T[None]), home)
    assert bool(ok[0])
    psm2.setpoint[:], psm2.measured[:] = q, q
    events = cart.tick()
    warnings = {(e.env, e.value) for e in events if e.topic == "warning"}
    assert warnings == {(0, "PSM1: collides with PSM2 (their instruments touch)"),
                        (1, "PSM2: collides with PSM1 (their instruments touch)")}
    assert [e for e in cart.tick() if e.topic == "warning"] == []  # said once, while they touch
    psm2.setpoint[:], psm2.measured[:] = home, home
    assert {(e.env, e.value) for e in cart.tick() if e.topic == "status"} == {(0, "PSM1: clear of PSM2"),
                                                                            (1, "PSM2: clear of PSM1")}


def test_a_cart_refuses_what_it_cannot_run():
    from cressim.twin import ConfigError

    scene = load_scene("patient_cart.yaml")
    with pytest.raises(ConfigError, match="patient_cart.yaml: num_envs: a patient cart runs in one env"):
        Cart(TwinConfig(scene=scene, num_envs=2))
    with pytest.raises(ConfigError, match="patient_cart.yaml: dynamics: a patient cart's arms are kinematic"):
        Cart(TwinConfig(scene=scene, dynamics="dynamic"))


def test_ecm_inverse_kinematics_and_move_cp():
    """The ECM's closed-form IK inverts the dVRK's DH FK over its joint ranges; move_cp reaches the
    pose and a pose off the RCM's line is refused."""
    from types import SimpleNamespace

    from cressim.robots.ecm import ECM_LOWER, ECM_UPPER, ecm_inverse_kinematics
    from cressim.robots.kinematics import matrix_to_pose7
    from cressim.twin.ecm_arm import EcmArm

    rng = np.random.default_rng(0)
    q = ECM_LOWER + (ECM_UPPER - ECM_LOWER) * rng.random((500, 4))
    q[:, 2] = np.maximum(q[:, 2], 0.01)  # the tip past the RCM
    for qi in q:
        back, ok = ecm_inverse_kinematics(ecm_forward_kinematics(qi))
        assert ok and np.allclose(back, qi, atol=1e-8)

    def pose(T):  # what a geometry_msgs/Pose carries (no ROS here)
        x, y, z, qx, qy, qz, qw = map(float, matrix_to_pose7(torch.as_tensor(T[None]))[0].numpy())
        return SimpleNamespace(position=SimpleNamespace(x=x, y=y, z=z),
                               orientation=SimpleNamespace(x=qx, y=qy, z=qz, w=qw))

    ecm = EcmArm((0, 0, 0.05, 0), (0, 0, 0.05, 0), publish_rate=100.0)
    ecm.state_command(0, "enable")
    ecm.state_command(0, "home")
    while ecm.states[0].is_busy or not ecm.states[0].is_homed:
        ecm.tick()
    goal = np.array([0.2, -0.1, 0.08, 0.3])
    assert [e.topic for e in ecm.move_cp(0, pose(ecm_forward_kinematics(goal)))] == ["operating_state"]
    events = []
    while ecm.states[0].is_busy:
        events += pairs(ecm.tick())
    assert ("goal_reached", True) in events and np.allclose(ecm.setpoint[0], goal, atol=1e-9)
    # beside the scope's line, the z no longer along it: the dVRK's ECM re-aligns the goal's z to
    # the line from the RCM to its position and goes there (its IK turns the scope onto the point)
    off = ecm_forward_kinematics(goal)
    off[:3, 3] += 0.01 * off[:3, 0]
    assert [e.topic for e in ecm.move_cp(0, pose(off))] == ["operating_state"]
    while ecm.states[0].is_busy:
        ecm.tick()
    for _ in range(10):  # measured settles (the 5 ms lag)
        ecm.tick()
    tip = ecm.local_cp("measured")
    assert np.allclose(tip[:3, 3], off[:3, 3], atol=1e-6)
    assert np.allclose(tip[:3, 2], off[:3, 3] / np.linalg.norm(off[:3, 3]), atol=1e-9)  # z along the scope's line
    far = ecm_forward_kinematics(np.array([0.2, -0.1, ECM_UPPER[2], 0.3]))
    far[:3, 3] *= 1.5  # past the insertion's limit: no joint values reach it
    (event,) = ecm.move_cp(0, pose(far))
    assert event.topic == "error" and "not reachable" in event.value


def test_the_camera_pedal_moves_the_ecm_with_the_hands(make_cart):
    """Camera pedal pressed (operator present, ECM enabled and homed): the endoscope's tip follows
    the midpoint of the hands in the camera's frame at the press (left/right and up/down turn the
    ECM about its RCM, in/out inserts it), the PSMs hold and refuse motion; released, the ECM stays
    and the PSMs take commands again."""
    from cressim.twin import JointCommand

    cart = make_cart(load_scene("patient_cart.yaml"))
    for row in range(cart.num_envs):
        cart.state_command(row, "enable")
        cart.state_command(row, "home")
    cart.ecm.state_command(0, "enable")
    cart.ecm.state_command(0, "home")
    for arm in cart.mtms:
        arm.state_command("enable")
        arm.state_command("home")
    while any(arm.states[0].is_busy for arm in cart.psms) or cart.ecm.states[0].is_busy:
        cart.tick()
    op = cart.operator
    op.present, op.hands = True, {"MTML": np.array([-0.05, 0.0, 0.0]), "MTMR": np.array([0.05, 0.0, 0.0])}
    cart.tick()
    psm1 = cart.psms[0].measured.clone()
    tip0 = cart.ecm.local_cp("measured")
    q0 = cart.ecm.measured[0].numpy().copy()
    op.camera = True
    cart.tick()
    assert ("status", "ECM: camera control: the endoscope follows the hands") in cart.ecm_events
    (event,) = cart.servo_jp(0, JointCommand(position=[0.3, 0.0, 0.12, 0.0, 0.0, 0.0]))
    assert event.topic == "warning" and "camera pedal is pressed" in event.value
    d = np.array([0.01, -0.006, 0.015])  # right, up, in: both hands
    for k in range(1, 21):
        op.hands = {"MTML": np.array([-0.05, 0.0, 0.0]) + d * k / 20, "MTMR": np.array([0.05, 0.0, 0.0]) + d * k / 20}
        cart.tick()
    for _ in range(10):  # measured settles (the 5 ms lag)
        cart.tick()
    tip = cart.ecm.local_cp("measured")
    assert np.allclose(tip[:3, 3] - tip0[:3, 3], tip0[:3, :3] @ d, atol=1e-6)
    assert np.linalg.norm(cart.ecm.measured[0].numpy() - q0) > 0.01
    assert torch.allclose(cart.psms[0].measured, psm1, atol=1e-9)  # the PSM held
    op.camera = False
    cart.tick()
    assert ("status", "ECM: camera control released") in cart.ecm_events
    q1 = cart.ecm.measured[0].numpy().copy()
    op.hands = {"MTML": np.array([-0.05, 0.0, 0.0]), "MTMR": np.array([0.05, 0.0, 0.0])}
    for _ in range(5):
        cart.tick()
    assert np.allclose(cart.ecm.measured[0].numpy(), q1, atol=1e-9)  # released: the hands no longer move it
    assert cart.servo_jp(0, JointCommand(position=[0.3, 0.0, 0.12, 0.0, 0.0, 0.0])) == []


def test_psms_with_different_tools_tick_in_one_cart(make_cart):
    """PSMs of two instruments: one TwinArms per instrument, each batched over its PSMs; commands,
    events and the snapshot are by the cart's rows whatever TwinArms holds them."""
    from cressim.twin import JointCommand

    scene = parse_scene("cart:\n  ECM: {}\n"
                        "  PSM1: {robot: psm_suction, base: {position: [0.0, -0.06, 0.30]}}\n"
                        "  PSM2: {base: {position: [0.0, 0.06, 0.30]}}\n"
                        "  PSM3: {robot: psm_suction, base: {position: [0.06, 0.0, 0.30]}}\n", "cart.yaml")
    cart = make_cart(scene)
    assert [rows for _, rows in cart.groups] == [[0, 2], [1]]
    for row in range(3):
        cart.state_command(row, "enable")
        cart.state_command(row, "home")
    while any(arm.states[0].is_busy for arm in cart.psms):
        cart.tick()
    goals = [[0.1, 0.0, 0.11, 0.2, 0.0, 0.0], [0.2, -0.1, 0.12, 0.0, 0.1, 0.0], [-0.1, 0.1, 0.1, -0.3, 0.0, 0.0]]
    for row, q in enumerate(goals):
        events = cart.move_jp(row, JointCommand(position=q))
        assert {e.env for e in events} == {row}
    done = []
    while len(done) < 3:
        done += [e.env for e in cart.tick() if e.topic == "goal_reached" and e.value]
    assert sorted(done) == [0, 1, 2]
    snap = cart.snapshot()
    for row, q in enumerate(goals):
        assert np.allclose(snap.setpoint[row], q, atol=1e-9), (row, snap.setpoint[row])
        assert np.allclose(cart.psms[row].setpoint[0], q, atol=1e-9)
    assert cart.jaw_move_jp(0, JointCommand(position=[0.5]))[0].value.startswith("jaw/move_jp refused")  # no jaw
    assert cart.jaw_move_jp(1, JointCommand(position=[0.5]))[0].topic == "operating_state"
