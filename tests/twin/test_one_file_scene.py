"""One scene file for a task's world and its twin: scenes/tissue_retraction.yaml's world with the
twin's sections of scenes/psm_retraction.yaml (its arm, camera, sensors) in the same file, read
by the engine's loader (which passes over the twin's sections) and by the twin's (which takes
the file as its world); a TwinArms built from it grasps the flap as the two-file scene's does."""
from pathlib import Path

import pytest

from cressim.scene_file import load_scene as load_world
from cressim.twin import JointCommand, SceneError, TwinArms, TwinConfig
from cressim.twin_scene_file import load_scene, parse_scene

from arm_moves import jaws_at, settle

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def one_file(tmp_path, extra: str = "") -> Path:
    """tissue_retraction.yaml with psm_retraction.yaml's twin sections (all but `world:`)."""
    twin = "".join(line for line in (SCENES / "psm_retraction.yaml").read_text().splitlines(True)
                   if not line.startswith("world:"))
    path = tmp_path / "retraction.yaml"
    path.write_text((SCENES / "tissue_retraction.yaml").read_text() + twin + extra)
    return path


def test_a_world_and_its_twin_in_one_file_drive_the_arm(tmp_path):
    path = one_file(tmp_path)
    scene = load_scene(str(path))
    two_files = load_scene("psm_retraction.yaml")
    assert scene.world == str(path) and two_files.world.endswith("tissue_retraction.yaml")
    assert (scene.robot, scene.home_jp, scene.grasp_reach, scene.camera_position) == \
        (two_files.robot, two_files.home_jp, two_files.grasp_reach, two_files.camera_position)
    world = load_world(path)  # the engine's loader: the world alone, the twin's sections passed over
    alone = load_world(SCENES / "tissue_retraction.yaml")
    assert [world.entity(i).name for i in range(world.entity_count)] == \
        [alone.entity(i).name for i in range(alone.entity_count)]
    arms = TwinArms(TwinConfig(scene=scene, camera_width=64, camera_height=48))
    assert arms.simulated and arms.instrument("jaws") is not None
    assert arms.bodies.engine.buffer("particles.positions").read().shape[0] == 372  # the flap and the thread
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    settle(arms)
    jaws_at(arms, 0.02, jaws=[0.8])
    jaws_at(arms, 0.0)
    arms.jaw_move_jp(0, JointCommand(position=[-0.2]))
    settle(arms)
    assert arms.instrument("jaws").grasp.held()[0] > 0  # the jaws took the flap's edge
    assert arms.bodies.engine.validation_messages == []


def test_the_one_file_keeps_each_readers_checks(tmp_path):
    text = one_file(tmp_path).read_text()
    assert parse_scene(text.replace("envs: 1", "envs: 2")).num_envs == 2  # the world's envs are the twin's
    bad = text + "num_envs: 2\n"  # the world says envs: 1
    with pytest.raises(SceneError, match=r"retraction.yaml:9:7: envs: 1 envs, but num_envs is 2"):
        parse_scene(bad, str(tmp_path / "retraction.yaml"))
    line = len(text.splitlines()) + 1
    with pytest.raises(SceneError, match=rf"retraction.yaml:{line}:8: world: this file is a world itself"):
        parse_scene(text + "world: tissue_retraction.yaml\n", str(tmp_path / "retraction.yaml"))
    (tmp_path / "typo.yaml").write_text(text + "arms: {}\n")  # neither reader's section: both refuse it
    with pytest.raises(SceneError, match=rf"typo.yaml:{line}:1: arms: unknown field 'arms'.*did you mean 'arm'"):
        load_scene(str(tmp_path / "typo.yaml"))
    with pytest.raises(SceneError, match=rf"typo.yaml:{line}:1: arms: unknown field"):
        load_world(tmp_path / "typo.yaml")
    # a twin section's bad value is the twin's to find, with its place
    arm_line = next(i for i, l in enumerate(text.splitlines(), 1) if l.startswith("  robot:"))
    with pytest.raises(SceneError, match=rf"retraction.yaml:{arm_line}:10: arm.robot: 'psm_foo' is not one of"):
        parse_scene(text.replace("  robot: psm_lnd", "  robot: psm_foo"), str(tmp_path / "retraction.yaml"))
