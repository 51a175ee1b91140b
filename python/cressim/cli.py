"""The `cressim` command line: `cressim info`, `demo`, `render`, `train`, `eval`, `generate`, `bench`."""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path


def _info(args: argparse.Namespace) -> int:
    import cressim

    devices = cressim.list_devices()
    for d in devices:
        print(f"device {d['index']}: {d['name']} ({d['type']}, Vulkan {d['vulkan']}, {d['driver']})")
    engine = cressim.Engine(cressim.World(cressim.SceneLayout(1)), device=args.device)
    info = engine.device
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    print(f"chosen: device {info['index']}: {info['name']}")
    for key in ("type", "vulkan", "driver", "subgroup_size", "max_storage_buffer_range",
                "max_compute_work_group_count", "max_compute_work_group_invocations",
                "timestamp_period_ns", "unified_memory", "external_memory_fd", "external_semaphore_fd",
                "validation"):
        print(f"  {key:36s} {info[key]}")
    return 0


def _demo(args: argparse.Namespace) -> int:
    if args.scene in ("soft", "fluid", "thread"):
        from cressim.demos.particles import run

        return run(args.scene, frames=args.frames or 120, out_dir=args.out)
    if args.scene == "cautery":
        from cressim.demos.cautery import run

        return run(frames=args.frames or 480, out_dir=args.out, num_envs=args.envs or 1)
    if args.scene == "cable":
        from cressim.demos.cable import run

        return run(frames=args.frames, out_dir=args.out, num_envs=args.envs or 1)
    if args.scene == "suture":
        from cressim.demos.suture import run

        return run(frames=args.frames, out_dir=args.out, num_envs=args.envs or 1)
    if args.scene == "ultrasound":
        from cressim.demos.ultrasound import run

        return run(out_dir=args.out)
    from cressim.demos.batched_scene import run

    return run(num_envs=args.envs or 16, frames=args.frames or 120, out_dir=args.out)


def _render(args: argparse.Namespace) -> int:
    from cressim import AuthoringError
    from cressim.render_scene import render
    from cressim.scene_file import SceneFileError

    try:
        paths = render(args.scene, args.out, all_envs=args.all_envs, steps=args.steps, device=args.device)
    except (SceneFileError, AuthoringError, FileNotFoundError) as e:
        print(f"cressim render: {e}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0


def _task_options(pairs: list[str]) -> dict:
    """KEY=VALUE strings -> keywords of a task's constructor (numbers parsed as YAML does)."""
    import yaml

    options = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key.isidentifier():
            raise SystemExit(f"--task-option {pair!r}: expected KEY=VALUE (e.g. observation=crtk)")
        options[key] = yaml.safe_load(value)
    return options


def _env_list(text: str) -> list:
    """--video-envs: comma-separated env indices."""
    try:
        return [int(v) for v in text.split(",")]
    except ValueError:
        raise SystemExit(f"--video-envs {text!r}: expected comma-separated env indices (e.g. 0,3)") from None
def _torchrun(nproc: int, argv: list[str]) -> int:
    """`cressim ARGV` in `nproc` processes on this host, started by torchrun (torch.distributed.run)."""
    import subprocess

    command = [sys.executable, "-m", "torch.distributed.run", "--standalone", f"--nproc-per-node={nproc}",
               "-m", "cressim", *argv]
    return subprocess.run(command).returncode


def _relaunched(args: argparse.Namespace) -> int | None:
    """`--nproc N` outside a launcher: this command again in N processes under torchrun (its exit
    status); None where this process is to do the work itself."""
    from cressim.learn.distributed import launched

    if args.nproc < 1:
        raise SystemExit(f"--nproc {args.nproc}: at least 1 process")
    if args.nproc > 1 and not launched():
        return _torchrun(args.nproc, _without_nproc(args.argv))
    return None


def _leader() -> bool:
    """Rank 0 of a torchrun launch, or the only process: the one that reports."""
    return os.environ.get("RANK", "0") == "0"


def _without_nproc(argv: list[str]) -> list[str]:
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
        elif a == "--nproc":
            skip = True
        elif not a.startswith("--nproc="):
            out.append(a)
    return out


def _train(args: argparse.Namespace) -> int:
    from cressim.learn import train

    rc = _relaunched(args)
    if rc is not None:
        return rc

    result = train(args.task, num_envs=args.envs, iterations=args.iterations, device=args.device, seed=args.seed,
                   out_dir=args.out or f"runs/{args.task.lower()}", rollout=args.rollout, save_every=args.save_every,
                   backend=args.backend, minibatch=args.minibatch, task_options=_task_options(args.task_option),
                   obs_normalization=args.obs_normalization or None, compile=args.compile or None,
                   fused_update=args.fused_update,
                   video_envs=_env_list(args.video_envs) if args.video else None, engine_rollout=args.engine_rollout)
    if not _leader():
        return 0
    last = result["history"][-1]
    print(f"done in {result['wall_s']:.1f} s ({result['backend']}): {last['env_steps']:,} env steps, "
          f"mean episode length {last['mean_length']:.1f}, return {last['mean_return']:.1f}, "
          f"terminated {last['terminated']:.2f}; "
          f"checkpoint {result['checkpoint']}, plot {result['plot']}")
    return 0


def _eval(args: argparse.Namespace) -> int:
    from cressim.learn import evaluate

    result = evaluate(args.checkpoint, num_envs=args.envs, episodes=args.episodes, device=args.device, seed=args.seed,
                      task_options=_task_options(args.task_option), video_dir=args.video,
                      video_envs=_env_list(args.video_envs))
    print(f"{result['task']}: {result['episodes']} episodes of the mean policy ({result['vulkan_device']}): "
          f"return {result['mean_return']:.2f}, length {result['mean_length']:.1f}, "
          f"terminated {result['terminated']:.3f}")
    for video in result["videos"]:
        print(video)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(result, indent=1))
    return 0


def _generate(args: argparse.Namespace) -> int:
    from cressim.datasets import generate

    rc = _relaunched(args)
    if rc is not None:
        return rc
    index = generate(args.task, args.envs, args.steps, args.out, policy=args.policy, seed=args.seed,
                     task_options=_task_options(args.task_option), device=args.device)
    if _leader():
        print(f"{args.out}/index.json: {index['steps']} steps of {index['num_envs']} envs of {args.task} "
              f"in {len(index['shards'])} shard(s)")
    return 0


def _export(args: argparse.Namespace) -> int:
    from cressim import datasets

    if args.replay:
        result = datasets.replay(args.source, device=args.device)
        print(json.dumps(result))
        return 0 if result["max_abs_difference"] <= args.tolerance else 1
    if not args.out:
        raise SystemExit("cressim export: --out is needed (a new folder for lerobot, a new .hdf5 file for robomimic)")
    write = datasets.to_lerobot if args.format == "lerobot" else datasets.to_robomimic
    bag = {} if (Path(args.source) / "index.json").is_file() else {"fps": args.fps, "ns": args.ns}
    print(write(args.source, args.out, **bag))
    return 0


def _bench(args: argparse.Namespace) -> int:
    from cressim.learn.bench import run

    run(args.task, [int(n) for n in args.envs.split(",")] if args.envs else None, mode=args.mode, out_dir=args.out,
        device=args.device, backend=args.backend, extend=args.extend, minibatch=args.minibatch, policy=args.policy,
        compile=args.compile, fused_update=args.fused_update)
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="cressim", description="CRESSim: batched GPU simulation for surgical robotics")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("info", help="the Vulkan device, its version and limits")
    p.add_argument("--device", help="index or name substring (default: CRESSIM_DEVICE or the best device)")
    p.add_argument("--json", action="store_true", help="print the chosen device as JSON")
    p.set_defaults(run=_info)
    p = sub.add_parser("demo", help="the main job on the default scene")
    p.add_argument("scene", nargs="?", default="batched", choices=("batched", "soft", "fluid", "thread", "cautery", "cable", "suture",
                                                             "ultrasound"),
                   help="batched: a batched scene and a custom compute pass (default); soft, fluid, thread: "
                        "particle scenes saved as particle-state sequences (.npz) and a few rendered frames (PNG "
                        "colour, segmentation); cautery: an energized hook coagulates and cuts a track in liver; "
                        "cable: a tendon-driven continuum robot bends, sweeps and carries a load; suture: a "
                        "needle sews two bites across a wound and the stitch is pulled tight to a tension; "
                        "ultrasound: a B-mode image of fat over liver with a cyst and a shadowing calcification. "
                        "The twin's demo is ROS's: `python -m cressim_ros.demo`")
    p.add_argument("--envs", type=int, help="batched: envs (default 16); cautery, cable, suture: envs (default 1)")
    p.add_argument("--frames", type=int, help="frames (default 120; cautery 480; cable, suture: the whole sequence)")
    p.add_argument("--out", default="out/demo", help="folder for the demo's outputs")
    p.set_defaults(run=_demo)
    p = sub.add_parser("render", help="PNG images of a scene file's cameras (RGB, depth, segmentation)")
    p.add_argument("scene", help="a scene YAML file (cressim/scene_file.py describes the format; scenes/ has examples)")
    p.add_argument("--out", default="out/render", help="folder for the images")
    p.add_argument("--all-envs", action="store_true", help="every env's cameras (default: env 0's)")
    p.add_argument("--steps", type=int, default=0, help="physics steps before the picture")
    p.add_argument("--device", help="Vulkan device index or name substring")
    p.set_defaults(run=_render)
    p = sub.add_parser("train", help="PPO on a batched task (rsl-rl-lib when installed, else built-in)")
    p.add_argument("task", nargs="?", default="CartPole")
    p.add_argument("--envs", type=int, default=4096)
    p.add_argument("--iterations", type=int, default=200, help="PPO updates")
    p.add_argument("--device", help="torch device of env and learner (default: what the env picks)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", help="folder for checkpoints, metrics and plot (default runs/<task>)")
    p.add_argument("--rollout", type=int, help="steps per env per update (default 128)")
    p.add_argument("--save-every", type=int, default=50, help="checkpoint every K updates")
    p.add_argument("--backend", default="auto", choices=("auto", "rsl_rl", "torch"))
    p.add_argument("--minibatch", type=int, help="samples per minibatch (default: the paper's, 2048 for CartPole)")
    p.add_argument("--task-option", action="append", metavar="KEY=VALUE",
                   help="a keyword of the task's constructor, e.g. observation=crtk (repeatable)")
    p.add_argument("--nproc", type=int, default=1,
                   help="processes (one a GPU) under torch.distributed, --envs split among them; "
                        "runs torchrun, as `torchrun --nproc-per-node N -m cressim train ...` does")
    p.add_argument("--obs-normalization", action="store_true",
                   help="the observation's numbers by their running mean and std (PPOConfig.obs_normalization)")
    p.add_argument("--video", action="store_true",
                   help="MP4s of the --video-envs in each checkpoint's rollout (--out/video_<k>_env<i>.mp4, PyAV)")
    p.add_argument("--video-envs", default="0", help="comma-separated env indices filmed (default 0)")
    p.add_argument("--compile", action="store_true",
                   help="the built-in learner's minibatch step through torch.compile (PPOConfig.compile)")
    p.add_argument("--fused-update", default="auto", choices=("auto", "on", "off"),
                   help="the built-in learner's update as fused Triton kernels in one CUDA graph (PPOConfig.fused_update; "
                        "auto: where it applies, TASKS.md's MLPs of width <= 128 on CUDA)")
    p.add_argument("--engine-rollout", action="store_true",
                   help="the actor (an MLP, or TASKS.md's CNN) runs inside the engine's frame, a whole rollout a submit; "
                        "torch only learns")
    p.set_defaults(run=_train)
    p = sub.add_parser("generate", help="record batched rollouts to MCAP bags, one a process, with an index")
    p.add_argument("task", nargs="?", default="CartPole")
    p.add_argument("--envs", type=int, default=64, help="envs in all (split among --nproc processes)")
    p.add_argument("--steps", type=int, default=100, help="steps of every env")
    p.add_argument("--policy", help="`cressim train`'s policy.pt (mean actions; default: uniform in [-1, 1])")
    p.add_argument("--out", default="out/rollouts", help="a new folder: shard_<rank>/ bags and index.json")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--device", help="torch device (default: what the env picks; cuda:LOCAL_RANK under torchrun)")
    p.add_argument("--nproc", type=int, default=1, help="processes (one a GPU) under torch.distributed, as in train")
    p.add_argument("--task-option", action="append", metavar="KEY=VALUE",
                   help="a keyword of the task's constructor (repeatable)")
    p.set_defaults(run=_generate)

    p = sub.add_parser("export", help="generated rollouts as a LeRobot (v2.1) or robomimic (HDF5) dataset; "
                                      "--replay runs a dataset again and compares")
    p.add_argument("source", help="`cressim generate`'s folder or a twin recording (rosbag2 folder); "
                                   "with --replay, an exported dataset")
    p.add_argument("--fps", type=float, default=30.0, help="a twin recording's frames per second (default 30)")
    p.add_argument("--ns", default="PSM1", help="a twin recording's arm namespace (default PSM1)")
    p.add_argument("--format", default="lerobot", choices=("lerobot", "robomimic"))
    p.add_argument("--out", help="lerobot: a new folder; robomimic: a new .hdf5 file")
    p.add_argument("--replay", action="store_true", help="replay SOURCE (a dataset) in a batch and compare observations")
    p.add_argument("--tolerance", type=float, default=0.0, help="--replay: the largest difference that passes")
    p.add_argument("--device", help="--replay: torch device of the envs")
    p.set_defaults(run=_export)

    p = sub.add_parser("eval", help="a trained policy's mean actions on its task: return, length, success share")
    p.add_argument("checkpoint", help="`cressim train`'s policy.pt or model_<k>.pt (built-in learner)")
    p.add_argument("--envs", type=int, default=64)
    p.add_argument("--episodes", type=int, default=1, help="episodes per env")
    p.add_argument("--device", help="torch device of env and policy (default: what the env picks)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--task-option", action="append", metavar="KEY=VALUE",
                   help="override a keyword the task was trained with (repeatable)")
    p.add_argument("--json", help="write the result (every episode's return, length, ending) here")
    p.add_argument("--video", metavar="DIR", help="MP4s of the --video-envs' episodes here (eval_env<i>.mp4, PyAV)")
    p.add_argument("--video-envs", default="0", help="comma-separated env indices filmed (default 0)")
    p.set_defaults(run=_eval)
    p = sub.add_parser("bench", help="stepping, policy-in-the-loop and PPO throughput (TASKS.md protocol)")
    p.add_argument("task", nargs="?", default="CartPole")
    p.add_argument("--envs", help="comma-separated counts (default: TASKS.md's sweep for the task, "
                                  "1,8,...,8192 for CartPole, 1,8,32,64 for UltrasoundScan, 1,8,...,256 for BloodSuction)")
    p.add_argument("--mode", default="both", choices=("step", "policy", "ppo", "both", "all"),
                   help="step: zero actions, copied each step and in place; policy: a rollout with the PPO actor in "
                        "the loop, in torch and in the engine; ppo: PPO end to end; both: step and ppo; all: the three")
    p.add_argument("--policy", default="auto", choices=("auto", "engine", "torch"),
                   help="where PPO's actor runs (auto: in the engine where the task's actor is an MLP)")
    p.add_argument("--compile", action="store_true",
                   help="the built-in learner's minibatch step through torch.compile (PPOConfig.compile)")
    p.add_argument("--fused-update", default="auto", choices=("auto", "on", "off"),
                   help="the built-in learner's update as fused Triton kernels in one CUDA graph (PPOConfig.fused_update; "
                        "auto: where it applies, TASKS.md's MLPs of width <= 128 on CUDA)")
    p.add_argument("--out", default="benchmarks/results", help="folder for the JSON and PNG")
    p.add_argument("--device", help="torch device (default: what the env picks)")
    p.add_argument("--backend", default="auto", choices=("auto", "rsl_rl", "torch"), help="PPO learner")
    p.add_argument("--extend", action="store_true", help="keep doubling envs while step throughput rises >= 5%%")
    p.add_argument("--minibatch", type=int, help="PPO samples per minibatch (default: the paper's, 2048 for CartPole)")
    p.set_defaults(run=_bench)
    try:  # record, replay: need mcap and rosbags, which a bare machine (the GPU one) may lack
        from cressim.record.cli import register
    except ImportError as exc:
        for name in ("record", "replay"):
            p = sub.add_parser(name, help=f"unavailable here: {exc}")
            p.set_defaults(run=lambda args, exc=exc: sys.exit(f"cressim {args.command}: needs {exc.name} ({exc})"))
    else:
        register(sub)
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    args.argv = argv
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
