"""Randomization in a batched task (CartPole): reset terms redraw exactly in the envs whose
episode ended (the others keep theirs), interval terms every `every` steps, the bodies carry the
draws, `reset(seed=...)` reproduces the run, and a YAML file configures it (errors with file:line)."""
import numpy as np
import pytest
import torch

import cressim
import cressim.envs
from cressim.scene_file import SceneFileError

TERMS = [dict(param="mass", entity="pole", range=[0.5, 2.0], operation="scale", name="pole_mass"),
         dict(param="mass", entity="cart", distribution="log_uniform", range=[0.5, 2.0], operation="abs",
              when="interval", every=20, name="cart_mass")]


def inverse_masses(env, name):
    """Each env's inverse mass of its body named `name`, from the engine's model buffer."""
    e = env.engine
    entity = e.buffer("rigid.body_entity").read().ravel()
    bodies = e.buffer("rigid.bodies").read().view(np.float32).reshape(len(entity), -1)
    rows = [b for b, ent in enumerate(entity) if e.world.entity(int(ent)).name == name]
    return bodies[rows, 3]


def test_reset_terms_redraw_in_finished_envs_only_and_interval_terms_on_schedule():
    env = cressim.envs.make("CartPole", num_envs=6, seed=1, validation=True, randomization=TERMS)
    env.reset()
    pole, cart = env.randomized("pole_mass").clone(), env.randomized("cart_mass").clone()
    assert env.randomized().shape == (6, 2)
    ends = 0
    for step in range(1, 61):
        _, _, terminated, truncated, _ = env.step(torch.zeros(6, 1, device=env.device))
        done = (terminated | truncated).cpu().numpy()
        now_pole, now_cart = env.randomized("pole_mass").clone(), env.randomized("cart_mass").clone()
        np.testing.assert_array_equal((now_pole != pole).cpu().numpy()[:, 0], done)  # a finished env's next episode draws
        assert (now_cart != cart).all() if step % 20 == 0 else (now_cart == cart).all()
        np.testing.assert_allclose(inverse_masses(env, "pole"), 1 / (2.0 * now_pole[:, 0].cpu().numpy()), rtol=1e-6)
        np.testing.assert_allclose(inverse_masses(env, "cart"), 1 / now_cart[:, 0].cpu().numpy(), rtol=1e-6)
        pole, cart = now_pole, now_cart
        ends += int(done.sum())
    assert ends >= 3  # poles fell (zero actions)
    assert ((pole >= 0.5) & (pole <= 2.0)).all() and ((cart >= 0.5) & (cart <= 2.0)).all()
    assert env.engine.validation_messages == []


def test_the_same_seed_replays_the_same_draws_and_physics():
    def run(seed):
        env = cressim.envs.make("CartPole", num_envs=4, seed=0, randomization=TERMS)
        obs, _ = env.reset(seed=seed)
        out = [torch.cat([obs, env.randomized()], 1).clone()]
        for _ in range(25):
            obs, *_ = env.step(torch.full((4, 1), 0.3, device=env.device))
            out.append(torch.cat([obs, env.randomized()], 1).clone())
        return torch.stack(out)

    a = run(7)
    assert torch.equal(a, run(7))
    assert not torch.equal(a[0, :, 4:], run(8)[0, :, 4:])
    # the masses change the motion under the same actions: envs' carts differ in velocity
    assert a[-1, :, 1].unique().numel() == 4


def test_a_yaml_file_configures_the_task_and_its_errors_name_file_and_line(tmp_path):
    path = tmp_path / "randomize.yaml"
    path.write_text("- param: mass\n  entity: pole\n  range: [0.8, 1.2]\n  operation: scale\n")
    env = cressim.envs.make("CartPole", num_envs=2, randomization=path)
    env.reset()
    assert ((env.randomized("mass/pole") >= 0.8) & (env.randomized("mass/pole") <= 1.2)).all()
    path.write_text("- param: mass\n  entity: pole\n  range: [0.8, 1.2]\n  operation: scale\n  every: 3\n")
    with pytest.raises(SceneFileError, match=rf"{path}:5:10: \[0\]\.every: 'every' is for when: interval"):
        cressim.envs.make("CartPole", num_envs=2, randomization=path)
    with pytest.raises(ValueError, match=r"CartPole\(randomization=...\): randomization\[0\].entity: expected a name"):
        cressim.envs.make("CartPole", num_envs=2, randomization=[dict(param="mass", entity=3, range=[1, 2])])
    with pytest.raises(KeyError, match="no term named 'mass/cart'"):
        env.randomized("mass/cart")


def test_target_center_redraws_its_looks_when_act_ends_an_episode():
    class ShortTargetCenter(cressim.envs.TargetCenter):
        max_episode_steps = 3  # every env ends an episode every third step

    terms = [dict(param="color", entity="target", range=[[0.2, 1.0], [0.0, 0.3], [0.0, 0.3]], operation="abs"),
             dict(param="light_intensity", entity="sun", range=[0.5, 1.5], operation="scale", when="interval",
                  every=2)]
    env = ShortTargetCenter(3, image_size=32, seed=0, validation=True, randomization=terms)
    obs, _ = env.reset(seed=2)
    assert env.randomizer.seed == 2
    e = env.engine
    names = [e.world.entity(int(e.mapping["entity_id"][int(row)])).name for row in
             e.buffer("render.renderables").read().view(np.uint32).reshape(-1, 16)[:, 0]]
    target_rows = [i for i, n in enumerate(names) if n == "target"]
    color = env.randomized("color/target").clone()
    light = env.randomized("light_intensity/sun").clone()
    for step in range(1, 7):
        obs, _, terminated, truncated, info = env.step(torch.zeros(3, 2, device=env.device))
        ended = terminated | truncated
        done = ended.cpu().numpy()
        now = env.randomized("color/target").clone()
        np.testing.assert_array_equal((now != color).any(1).cpu().numpy(), done)
        assert (env.randomized("light_intensity/sun") != light).all() == (step % 2 == 0)
        light = env.randomized("light_intensity/sun").clone()
        drawn = e.buffer("render.renderables").read().view(np.float32).reshape(-1, 16)[target_rows, 4:7]
        np.testing.assert_allclose(drawn, now.cpu().numpy(), rtol=1e-6)
        if done.any():  # the final image still shows the last episode's colour, the new one the next
            assert not torch.equal(info["final_obs"][ended], obs[ended])
        color = now
    assert env.engine.validation_messages == []


def test_a_scene_files_randomization_runs_in_the_task_that_loads_it(tmp_path):
    # TissueRetract's scenes with a randomization section: the flap's stiffness and friction and the
    # table's friction, beside a term of the task's own
    from pathlib import Path

    scenes = Path(cressim.__file__).resolve().parents[2] / "scenes"
    world = tmp_path / "tissue_retraction.yaml"
    world.write_text((scenes / "tissue_retraction.yaml").read_text() + "randomization:\n"
                     "  - {param: youngs_modulus, entity: flap, range: [5e3, 20e3], operation: abs}\n"
                     "  - {param: friction, entity: flap, range: [0.8, 1.2], operation: scale}\n"
                     "  - {param: friction, entity: table, range: [0.3, 0.9], operation: abs}\n")
    twin = tmp_path / "psm_retraction.yaml"
    twin.write_text((scenes / "psm_retraction.yaml").read_text())  # its world: the file beside it
    env = cressim.envs.make("TissueRetract", num_envs=2, scene=str(twin), seed=4,
                            randomization=[dict(param="damping", entity="flap", range=[0.5, 2.0], operation="scale")])
    env.reset()
    assert env.randomizer.names == ["youngs_modulus/flap", "friction/flap", "friction/table", "damping/flap"]
    e = env.engine
    young = env.randomized("youngs_modulus/flap")[:, 0].cpu().numpy()
    assert ((young >= 5e3) & (young <= 20e3)).all() and young[0] != young[1]
    # every tet of an env's flap has its mu scaled by drawn / authored modulus (10 kPa)
    tets = e.buffer("particles.tet_constraints").read().view(np.float32).reshape(-1, 8)
    phases = e.buffer("particles.phases").read().reshape(-1, 4)
    objects = e.buffer("particles.objects").read().reshape(-1, 36)
    env_of_tet = objects[phases[tets[:, :4].view(np.uint32)[:, 0], 1], 2]
    nu = 0.45
    mu = 10e3 / (2 * (1 + nu))
    for k in range(2):
        np.testing.assert_allclose(tets[env_of_tet == k, 5], mu * young[k] / 10e3, rtol=1e-4)
    names = [e.world.entity(int(e.mapping["entity_id"][row])).name for row in objects[:, 4]]
    flap = objects.view(np.float32)[[n == "flap" for n in names]]  # one an env, in env order
    np.testing.assert_allclose(flap[:, 9], 0.5 * env.randomized("friction/flap")[:, 0].cpu().numpy(), rtol=1e-6)
    np.testing.assert_allclose(flap[:, 10], 2.0 * env.randomized("damping/flap")[:, 0].cpu().numpy(), rtol=1e-6)
    table = e.buffer("rigid.colliders").read().view(np.float32).reshape(-1, 20)[:, 12:14]
    drawn = env.randomized("friction/table")[:, 0].cpu().numpy()
    for d in drawn:  # each env's table: static and dynamic friction both the draw
        assert (np.isclose(table, d, rtol=1e-6).all(1)).sum() == 1
    assert not np.isclose(table[:, 0], 0.6).any()  # none kept the authored 0.6 (the arm's links have 0.5)
    with pytest.raises(ValueError, match="term name 'friction/table' is also used at .*tissue_retraction.yaml:"):
        cressim.envs.make("TissueRetract", num_envs=1, scene=str(twin),
                          randomization=[dict(param="friction", entity="table", range=[0.1, 0.2])])


def test_depth_noise_needs_a_camera_the_task_renders():
    class CartPoleWithDepth(cressim.envs.CartPole):  # a depth camera that the step never renders
        def build_world(self, num_envs):
            world = super().build_world(num_envs)
            for env in range(num_envs):
                cam = world.create_entity(env=env, name="camera")
                cam.add(cressim.Transform(position=(0, -3, 1)))
                cam.add(cressim.Camera(width=16, height=16, products=["depth"]))
            return world

    noise = [dict(param="depth_noise", entity="camera", range=[0, 0.01], operation="abs")]
    with pytest.raises(ValueError, match="CartPoleWithDepth: depth_noise needs a camera the task renders every step"):
        CartPoleWithDepth(1, randomization=noise)
