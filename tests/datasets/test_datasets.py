"""Generated rollouts exported to LeRobot v2.1 and robomimic HDF5, read back with pyarrow, PyAV
and h5py (the formats' own building blocks; LeRobot itself pins torch < 2.11 and numpy < 2.3, so
it does not install beside this project), and replayed in a batch."""
import json

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest

from cressim.io import read_mp4, write_mp4
from cressim import datasets
from cressim.datasets.rollouts import generate, read


@pytest.fixture(scope="module")
def rollouts(tmp_path_factory):
    out = tmp_path_factory.mktemp("gen") / "cartpole"
    generate("CartPole", 4, 30, out, seed=7)
    return out


def test_episodes_split_at_every_ending(rollouts):
    arrays = read(rollouts)
    found = datasets.episodes(arrays)
    done = (arrays["terminated"] | arrays["truncated"]).astype(bool)
    assert len(found) == done.sum() > 4  # random actions drop CartPole's pole within a few steps
    for ep in found:
        assert done[ep.stop - 1, ep.env] and not done[ep.start:ep.stop - 1, ep.env].any()


def test_lerobot_layout_reads_back_and_replays(rollouts, tmp_path):
    dst = datasets.to_lerobot(rollouts, tmp_path / "lerobot")
    info = json.loads((dst / "meta" / "info.json").read_text())
    index = json.loads((rollouts / "index.json").read_text())
    assert info["codebase_version"] == "v2.1" and info["fps"] == pytest.approx(1 / index["dt"])
    lines = [json.loads(x) for x in (dst / "meta" / "episodes.jsonl").read_text().splitlines()]
    assert info["total_episodes"] == len(lines) and info["total_frames"] == sum(x["length"] for x in lines)
    arrays, first = read(rollouts), lines[0]
    table = pq.read_table(dst / info["data_path"].format(episode_chunk=0, episode_index=0))
    assert table.num_rows == first["length"]
    src = first["cressim"]
    state = np.stack(table.column("observation.state").to_numpy(zero_copy_only=False))
    want = arrays["observation"][src["start_step"]:src["start_step"] + first["length"], src["env"]]
    assert np.array_equal(state, want)
    assert np.array_equal(table.column("index").to_numpy(), np.arange(first["length"]))
    assert table.column("next.done").to_pylist()[-1] and not any(table.column("next.done").to_pylist()[:-1])
    stamps = table.column("timestamp").to_numpy()
    assert np.allclose(np.diff(stamps), 1 / info["fps"], rtol=1e-4)
    result = datasets.replay(dst)
    assert result["episodes"] == len(lines) and result["frames_compared"] == info["total_frames"]
    assert result["max_abs_difference"] == 0.0  # the same envs, seed and actions: the same states


def test_robomimic_file_reads_back_and_replays(rollouts, tmp_path):
    dst = datasets.to_robomimic(rollouts, tmp_path / "cartpole.hdf5")
    with h5py.File(dst, "r") as f:
        demos = [d.decode() for d in f["mask/train"][()]]
        assert f["data"].attrs["total"] == sum(f["data"][d].attrs["num_samples"] for d in demos)
        assert json.loads(f["data"].attrs["env_args"])["env_name"] == "CartPole"
        d0 = f["data"][demos[0]]
        n = d0.attrs["num_samples"]
        assert d0["actions"].shape == (n, 1) and d0["obs/state"].shape == (n, 4) and d0["dones"][-1] == 1
        assert np.array_equal(d0["next_obs/state"][:-1], d0["obs/state"][1:])
    result = datasets.replay(dst)
    assert result["max_abs_difference"] == 0.0 and result["frames_compared"] > 0


def test_image_observations_become_lossless_videos(tmp_path):
    """TargetCenter's RGB observations, recorded with their (H, W, 3) shape: an H.264 video (qp 0,
    yuv444p) decodes back to the recorded pixels within one level (RGB <-> YUV rounding)."""
    src = tmp_path / "tc"
    generate("TargetCenter", 2, 6, src, seed=1, task_options={"image_size": 32})
    frames = read(src)["observation"][:, 1]
    assert frames.shape == (6, 32, 32, 3) and frames.dtype == np.uint8 and frames.std() > 0
    back = read_mp4(write_mp4(tmp_path / "v.mp4", frames, 50.0, lossless=True))
    assert back.shape == frames.shape and np.abs(back.astype(int) - frames).max() <= 1


def test_a_twin_recording_becomes_one_episode_of_aligned_states_and_commands(tmp_path):
    """The synthetic PSM session (cressim.record.synthetic: servo_jp commands, the arm's lagged
    measured_js) as LeRobot and robomimic datasets at 50 Hz: each frame holds the latest measured
    joints and jaw and the latest command, at its time from the first command."""
    from cressim.record.reader import read_messages
    from cressim.record.synthetic import record_synthetic

    bag = tmp_path / "session"
    record_synthetic(bag, duration=2.0)
    dst = datasets.to_lerobot(bag, tmp_path / "lerobot", fps=50.0)
    info = json.loads((dst / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 1 and info["fps"] == 50.0 and info["robot_type"] == "dvrk_psm"
    table = pq.read_table(dst / info["data_path"].format(episode_chunk=0, episode_index=0))
    state = np.stack(table.column("observation.state").to_numpy(zero_copy_only=False))
    action = np.stack(table.column("action").to_numpy(zero_copy_only=False))
    stamps = table.column("timestamp").to_numpy()
    assert state.shape == (table.num_rows, 7) and action.shape == (table.num_rows, 7)
    assert table.num_rows == pytest.approx(1.5 * 50, abs=2)  # commands from 0.5 s to 2 s
    assert np.allclose(np.diff(stamps), 0.02)
    # frame k: the last command at or before its time, from the bag itself
    commands = [(m.log_time, np.asarray(msg.position)) for m, msg in read_messages(bag, "/PSM1/servo_jp", decode=True)]
    t0 = commands[0][0]
    for k in (0, 10, table.num_rows - 1):
        t = t0 + round(stamps[k] * 1e9)
        latest = [q for when, q in commands if when <= t + 1000][-1]
        np.testing.assert_allclose(action[k, :6], latest, atol=1e-6)
    assert np.abs(state[10:, :6] - action[10:, :6]).max() < 0.05  # after its lag the arm follows its commands
    with pytest.raises(ValueError, match="twin recording"):
        datasets.replay(dst)
    h5 = datasets.to_robomimic(bag, tmp_path / "session.hdf5", fps=50.0)
    with h5py.File(h5, "r") as f:
        assert f["data/demo_0/obs/state"].shape == (table.num_rows, 7)
        np.testing.assert_array_equal(f["data/demo_0/actions"][()], action)
        assert json.loads(f["data"].attrs["env_args"])["env_name"] == "cressim_twin"
