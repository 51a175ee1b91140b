"""Datasets for learning, made with the envs and the learner, kept in bags: batched rollouts of a
task recorded to rosbag2 MCAP bags (rollouts.py, `cressim generate`), and those rollouts or
recordings of the twin exported as LeRobot v2.1 or robomimic HDF5 datasets (clips.py, lerobot.py,
robomimic.py, `cressim export`) and replayed in a batch to check them (replay.py). Above envs and
learn; the bags themselves are cressim.record's.

    from cressim import datasets
    datasets.generate("CartPole", 64, 100, "out/rollouts")
    datasets.to_lerobot("out/rollouts", "out/lerobot")
    datasets.replay("out/lerobot")["max_abs_difference"]
"""
from .clips import Clip, Episode, bag_clips, clips, episodes, rollout_clips
from .lerobot import to_lerobot
from .replay import load, replay
from .robomimic import to_robomimic
from .rollouts import generate, read

__all__ = ["Clip", "Episode", "bag_clips", "clips", "episodes", "generate", "load", "read", "replay",
           "rollout_clips", "to_lerobot", "to_robomimic"]
