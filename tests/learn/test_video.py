"""Videos of chosen envs: render_mode="rgb_array" renders them after each step, cressim.io.write_mp4
encodes H.264 MP4s (PyAV) that decode back to the frames, and `cressim train --video` / `cressim eval --video`
write them for the envs asked for."""
import json

import numpy as np
import pytest
import torch

av = pytest.importorskip("av")  # PyAV: a dependency, but a bare GPU machine may lack it

import cressim.envs  # noqa: E402
from cressim.cli import main  # noqa: E402
from cressim.io import read_mp4, write_mp4  # noqa: E402
from cressim.learn.video import EnvVideo  # noqa: E402


def test_write_mp4_decodes_back_to_its_frames(tmp_path):
    frames = np.zeros((12, 48, 64, 3), np.uint8)
    for t in range(12):  # a red square moving right over grey
        frames[t] = 90
        frames[t, 16:32, 4 * t:4 * t + 16] = (220, 30, 30)
    back = read_mp4(write_mp4(tmp_path / "a.mp4", frames, fps=60))
    assert back.shape == frames.shape
    assert np.abs(back.astype(int) - frames).mean() < 4  # lossy, but the same pictures
    with pytest.raises(ValueError, match="yuv420p needs an even width and height"):
        write_mp4(tmp_path / "b.mp4", frames[:, :47], fps=60)
    with pytest.raises(ValueError, match=r"\(T > 0, H, W, 3\) uint8"):
        write_mp4(tmp_path / "c.mp4", frames.astype(np.float32), fps=60)


def test_render_shows_the_chosen_envs():
    env = cressim.envs.make("CartPole", num_envs=3, seed=0, render_mode="rgb_array", render_envs=(0, 2),
                            render_size=(160, 120))
    env.reset()
    first = env.render()
    assert first.shape == (2, 120, 160, 3) and first.dtype == np.uint8 and first.max() > 0
    for _ in range(40):  # unbalanced, the poles fall
        env.step(torch.zeros(3, 1))
    later = env.render()
    assert not np.array_equal(first, later)
    assert env.engine.cameras["env"].tolist() == [0, 2]  # a camera in the rendered envs only
    assert env.engine.validation_messages == []
    assert cressim.envs.make("CartPole", num_envs=1).render() is None
    with pytest.raises(ValueError, match=r"render_envs must be distinct env indices in \[0, 3\)"):
        cressim.envs.make("CartPole", num_envs=3, render_mode="rgb_array", render_envs=(3,))
    with pytest.raises(ValueError, match="render_size must be"):
        cressim.envs.make("CartPole", num_envs=3, render_mode="rgb_array", render_size=(101, 80))
    with pytest.raises(ValueError, match="EnvVideo: CartPole was made without render_mode"):
        EnvVideo(cressim.envs.make("CartPole", num_envs=1))


def test_train_and_eval_write_the_videos_asked_for(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["train", "CartPole", "--envs", "4", "--iterations", "2", "--rollout", "16", "--minibatch", "32",
                 "--save-every", "1", "--backend", "torch", "--out", str(out), "--video", "--video-envs", "0,3"]) == 0
    for k in (1, 2):
        for env in (0, 3):
            frames = read_mp4(out / f"video_{k}_env{env}.mp4")
            assert frames.shape == (16, 240, 320, 3)  # one frame per step of the update's rollout
    with av.open(str(out / "video_1_env0.mp4")) as container:
        assert container.streams.video[0].average_rate == 60  # real time: the tasks' 60 Hz frames
    assert not (out / "video_1_env1.mp4").exists()
    assert main(["eval", str(out / "policy.pt"), "--envs", "2", "--video", str(tmp_path / "eval"),
                 "--video-envs", "1", "--json", str(tmp_path / "eval.json")]) == 0
    printed = capsys.readouterr().out
    frames = read_mp4(tmp_path / "eval" / "eval_env1.mp4")  # the reset and every step of the evaluation
    steps = json.loads((tmp_path / "eval.json").read_text())["steps"]
    assert str(tmp_path / "eval" / "eval_env1.mp4") in printed and len(frames) == steps + 1
    with pytest.raises(SystemExit, match="--video-envs 'a'"):
        main(["eval", str(out / "policy.pt"), "--video", str(tmp_path), "--video-envs", "a"])
