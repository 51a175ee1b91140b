"""Randomization configs: draws follow the configured distributions (ranges and moments), the
same seed gives the same draws and an env's draws do not depend on the envs beside it (nor on
the shard it runs in), interval terms redraw at the configured steps, and bad configs are refused
naming the term, the field and what is wrong (file:line for YAML)."""
import math

import numpy as np
import pytest

import cressim
from cressim.randomization import RandomizationError, Randomizer, file_randomization
from cressim.scene_file import SceneFileError, load_scene

from .frames import randomized_frame


def blocks(make_engine, envs, kinematic_env=None):
    """A 1 kg block (and a collider) per env, nothing else."""
    world = cressim.World(cressim.SceneLayout(envs))
    for env in range(envs):
        b = world.create_entity(env=env, name="block")
        b.add(cressim.Transform(position=(0, 0, 0)))
        b.add(cressim.RigidBody(mass=1.0, linear_damping=0.1, angular_damping=0.1))
        b.add(cressim.Collider(cressim.Shape.box((0.1, 0.1, 0.1)), static_friction=0.5, group=0, mask=0))
    engine = make_engine(world)
    engine.physics = cressim.PhysicsSettings(gravity=(0, 0, 0), max_contacts_per_env=0)
    engine.prepare()
    engine.upload_world()
    return engine


def draws(make_engine, envs, terms, seed=0, env_offset=0):
    engine = blocks(make_engine, envs)
    r = Randomizer(engine, terms, seed=seed, env_offset=env_offset)
    randomized_frame(engine, r, reset_all=True, physics=False)
    return r.read()


TERMS = [dict(param="mass", entity="block", range=[0.5, 2.0], operation="abs"),
         dict(param="friction", entity="block", distribution="log_uniform", range=[0.1, 1.0], operation="abs"),
         dict(param="damping", entity="block", distribution="gaussian", mean=0.5, std=0.1, clip=[0.0, 1.0],
              operation="abs"),
         dict(param="restitution", entity="block", distribution="gaussian", mean=0.3, std=0.2, clip=[0.2, 0.4],
              operation="abs")]


def test_distributions_have_the_configured_ranges_and_moments(make_engine):
    n = 2048
    v = draws(make_engine, n, TERMS, seed=9)
    uniform, log_uniform, gaussian, clipped = v.T
    se = lambda sigma: 4 * sigma / math.sqrt(n)  # noqa: E731  (4 standard errors)
    assert 0.5 <= uniform.min() and uniform.max() <= 2.0 and uniform.min() < 0.51 and uniform.max() > 1.99
    assert abs(uniform.mean() - 1.25) < se(1.5 / math.sqrt(12))
    assert abs(uniform.var() / (1.5 ** 2 / 12) - 1) < 0.1
    logs = np.log(log_uniform)
    assert 0.1 <= log_uniform.min() and log_uniform.max() <= 1.0
    assert abs(logs.mean() - math.log(0.1) / 2) < se(math.log(10) / math.sqrt(12))
    assert abs(logs.var() / (math.log(10) ** 2 / 12) - 1) < 0.1
    assert abs(gaussian.mean() - 0.5) < se(0.1) and abs(gaussian.std() / 0.1 - 1) < 0.06
    assert abs(np.mean(np.abs(gaussian - 0.5) < 0.1) - 0.6827) < 0.04  # one sigma
    # clipped at +-0.5 sigma: 2 (1 - Phi(0.5)) = 61.7 % of the draws sit on the bounds
    assert clipped.min() >= 0.2 - 1e-7 and clipped.max() <= 0.4 + 1e-7
    on_bounds = np.mean((clipped <= 0.2 + 1e-6) | (clipped >= 0.4 - 1e-6))
    assert abs(on_bounds - 0.617) < 0.04
    # a choice: each value about as often
    choice = draws(make_engine, n, [dict(param="mass", entity="block", distribution="choice", choices=[0.5, 1.0, 3.0],
                                         operation="abs")], seed=9)[:, 0]
    assert set(choice) == {0.5, 1.0, 3.0}
    assert all(abs(np.mean(choice == c) - 1 / 3) < 4 * math.sqrt(2 / 9 / n) for c in (0.5, 1.0, 3.0))
    # terms and components are independent of each other
    assert abs(np.corrcoef(uniform, gaussian)[0, 1]) < 0.1 and abs(np.corrcoef(uniform, log_uniform)[0, 1]) < 0.1


def test_same_seed_same_draws_and_envs_independent_of_their_neighbours(make_engine):
    a, b = draws(make_engine, 8, TERMS, seed=5), draws(make_engine, 8, TERMS, seed=5)
    np.testing.assert_array_equal(a, b)
    # an env draws the same whatever the batch size, and a shard (env_offset) draws its envs' numbers
    np.testing.assert_array_equal(draws(make_engine, 3, TERMS, seed=5), a[:3])
    np.testing.assert_array_equal(draws(make_engine, 4, TERMS, seed=5, env_offset=4), a[4:])
    # a term draws the same whatever the terms beside it (its name salts its draws)
    np.testing.assert_array_equal(draws(make_engine, 8, TERMS[2:3], seed=5)[:, 0], a[:, 2])


def test_set_seed_restarts_nothing_but_changes_the_stream(make_engine):
    engine = blocks(make_engine, 4)
    r = Randomizer(engine, TERMS[:1], seed=1)
    randomized_frame(engine, r, reset_all=True, physics=False)
    first = r.read()
    r.set_seed(2)
    randomized_frame(engine, r, reset_all=True, physics=False)
    assert not np.isclose(first, r.read()).any()


def test_interval_terms_redraw_at_the_configured_steps_and_reset_terms_only_at_resets(make_engine):
    engine = blocks(make_engine, 3)
    r = Randomizer(engine, [dict(param="mass", entity="block", range=[0.5, 2.0], operation="abs", when="interval",
                                 every=3),
                            dict(param="friction", entity="block", range=[0.1, 0.9], operation="abs")], seed=2)
    randomized_frame(engine, r, reset_all=True, physics=False)
    history = [r.read()]
    for _ in range(9):
        randomized_frame(engine, r)
        history.append(r.read())
    mass = np.array([h[:, 0] for h in history])
    changed = [k for k in range(1, 10) if not np.array_equal(mass[k], mass[k - 1])]
    assert changed == [3, 6, 9]
    assert (mass[3] != mass[2]).all()  # every env redraws
    friction = np.array([h[:, 1] for h in history])
    assert (friction == friction[0]).all()  # no env reset: reset terms keep their draws
    inv = engine.buffer("rigid.bodies").read().view(np.float32).reshape(3, -1)[:, 3]
    np.testing.assert_allclose(inv, 1 / mass[-1], rtol=1e-6)  # the body has the latest draw
    assert [env for env, _ in r.targets("mass/block")] == [0, 1, 2]


def fails(engine, term, *match):
    with pytest.raises(RandomizationError) as e:
        Randomizer(engine, [term])
    for m in match:
        assert m in str(e.value), str(e.value)
    return str(e.value)


def test_bad_terms_are_refused_naming_the_field_and_the_problem(make_engine):
    engine = blocks(make_engine, 2)  # a refused term leaves nothing behind in it
    ok = dict(param="mass", entity="block", range=[0.5, 2.0])
    fails(engine, {**ok, "param": "mas"}, "randomization[0].param", "unknown parameter 'mas'", "mass, damping")
    fails(engine, {**ok, "rnage": [0, 1]}, "randomization[0].rnage", "unknown field 'rnage'")
    fails(engine, {**ok, "range": [2.0, 0.5]}, "randomization[0].range", "low must be <= high")
    fails(engine, {**ok, "range": [0.5, math.nan]}, "randomization[0].range[1]", "must be finite")
    fails(engine, {**ok, "range": [0.5, math.inf]}, "must be finite")
    fails(engine, {**ok, "range": [0.5]}, "expected [low, high]")
    fails(engine, {**ok, "range": "big"}, "expected a list")
    fails(engine, {**ok, "distribution": "log_uniform", "range": [0.0, 1.0]}, "log_uniform range must be positive")
    fails(engine, {**ok, "distribution": "normal"}, "unknown distribution 'normal'")
    fails(engine, dict(param="mass", entity="block", distribution="gaussian", mean=1.0), "needs 'std'")
    fails(engine, dict(param="mass", entity="block", distribution="gaussian", mean=1.0, std=-1.0), "std must be >= 0")
    fails(engine, {**ok, "operation": "multiply"}, "unknown operation 'multiply'")
    fails(engine, {**ok, "choices": [1, 2]}, "'choices' is for distribution: choice")
    fails(engine, dict(param="mass", entity="block", distribution="choice", choices=[]), "give at least one value")
    fails(engine, dict(param="texture", entity="block", range=[0, 1]), "texture takes distribution: choice")
    fails(engine, dict(param="texture", entity="block", distribution="choice", choices=[0.5], operation="abs"),
          "texture indices are integers >= -1")
    fails(engine, {**ok, "when": "interval"}, "needs every")
    fails(engine, {**ok, "when": "interval", "every": 0}, "randomization[0].every", "must be >= 1")
    fails(engine, {**ok, "every": 5}, "'every' is for when: interval")
    fails(engine, {**ok, "when": "often"}, "unknown 'when'")
    fails(engine, {**ok, "entity": "blok"}, "no rigid body or particle object named 'blok'", "(entities with one: block)")
    # values the parameter cannot take, found with the authored value
    fails(engine, {**ok, "operation": "add", "range": [-2.0, 1.0]}, "mass of 'block'", "authored 1 kg",
          "would reach [-1, 2]", "must stay in (0, inf]")
    fails(engine, dict(param="mass", entity="block", distribution="gaussian", mean=1.0, std=0.1),
          "a gaussian needs clip")
    fails(engine, dict(param="restitution", entity="block", range=[0.5, 1.5], operation="abs"), "must stay in [0, 1]")
    fails(engine, dict(param="color", entity="block", range=[0, 1]), "no renderable named 'block'")
    fails(engine, dict(param="camera_rotation", entity="block", range=[0, 1], operation="abs"),
          "takes the operations add, not abs")
    fails(engine, dict(param="color", entity="block", range=[[0, 1], [0, 1]]), "one [low, high] pair per component (3)")


def test_two_terms_on_one_field_and_kinematic_masses_are_refused(make_engine):
    engine = blocks(make_engine, 2)
    with pytest.raises(RandomizationError, match="already randomized by"):
        Randomizer(engine, [dict(param="mass", entity="block", range=[1, 2]),
                            dict(param="mass", entity="b*", range=[1, 2], name="again")])
    with pytest.raises(RandomizationError, match="name 'mass/block' is used twice"):
        Randomizer(engine, [dict(param="mass", entity="block", range=[1, 2]),
                            dict(param="mass", entity="block", range=[1, 2])])
    world = cressim.World(cressim.SceneLayout(1))
    k = world.create_entity(env=0, name="jaw")
    k.add(cressim.Transform())
    k.add(cressim.RigidBody(kinematic=True))
    k.add(cressim.Collider(cressim.Shape.box((0.1, 0.1, 0.1))))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    with pytest.raises(RandomizationError, match="'jaw' .* is kinematic"):
        Randomizer(engine, [dict(param="mass", entity="jaw", range=[1, 2])])


def test_scene_file_randomization_is_checked_with_file_and_line(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text("envs: 2\n"
                     "entities:\n"
                     "  - name: ball\n"
                     "    rigid_body: {mass: 1}\n"
                     "    collider: {shapes: [{sphere: {radius: 0.1}}]}\n"
                     "randomization:\n"
                     "  - {param: mass, entity: ball, range: [0.5, 2], operation: scale}\n"
                     "  - param: friction\n"
                     "    entity: ball\n"
                     "    range: [0.9, 0.1]\n")
    with pytest.raises(SceneFileError, match=rf"{scene}:10:12: randomization\[1\]\.range: low must be <= high"):
        load_scene(scene)
    with pytest.raises(SceneFileError, match=rf"{scene}:10:12: "):
        file_randomization(scene)
    scene.write_text(scene.read_text().replace("[0.9, 0.1]", "[0.1, 0.9]\n    when: interval\n    every: 30"))
    load_scene(scene)
    terms = file_randomization(scene)
    assert [(t.param, t.operation, t.when, t.every) for t in terms] == [("mass", "scale", "reset", 0),
                                                                          ("friction", "scale", "interval", 30)]
    assert terms[1].where.startswith(f"{scene}:8")
    # a texture choice names the file's textures
    textured = tmp_path / "textured.yaml"
    textured.write_text("textures:\n"
                        "  plain: {checker: {squares: 1}}\n"
                        "  checker: {checker: {squares: 8}}\n"
                        "entities:\n"
                        "  - name: floor\n"
                        "    renderable: {mesh: {box: {half_extents: [1, 1, 0.1]}}}\n"
                        "randomization:\n"
                        "  - {param: texture, entity: floor, distribution: choice, choices: [checker, plain, -1]}\n")
    assert file_randomization(textured)[0].choices == (1.0, 0.0, -1.0)
    load_scene(textured)
    textured.write_text(textured.read_text().replace("[checker, plain", "[checker, wood"))
    with pytest.raises(SceneFileError, match=rf"{textured}:8:78: randomization\[0\]\.choices\[1\]: no texture named "
                                             "'wood'; the textures are: plain, checker"):
        load_scene(textured)


def test_envs_reset_from_the_host_draw_their_reset_terms(make_engine):
    engine = blocks(make_engine, 3)
    r = Randomizer(engine, [dict(param="mass", entity="block", range=[0.5, 2.0], operation="abs")], seed=4)
    randomized_frame(engine, r, reset_all=True, physics=False)
    before = r.read()
    r.reset_envs([1])
    randomized_frame(engine, r)
    after = r.read()
    assert after[1, 0] != before[1, 0] and after[0, 0] == before[0, 0] and after[2, 0] == before[2, 0]
    randomized_frame(engine, r)  # once only
    np.testing.assert_array_equal(r.read(), after)
