"""The `cressim` command line: `cressim info`, `cressim demo`."""
from __future__ import annotations

import argparse
import json
import sys


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
    from cressim.demos.batched_scene import run

    return run(num_envs=args.envs, frames=args.frames, out_dir=args.out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="cressim", description="CRESSim: batched GPU simulation for surgical robotics")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("info", help="the Vulkan device, its version and limits")
    p.add_argument("--device", help="index or name substring (default: CRESSIM_DEVICE or the best device)")
    p.add_argument("--json", action="store_true", help="print the chosen device as JSON")
    p.set_defaults(run=_info)
    p = sub.add_parser("demo", help="the main job on the default scene")
    p.add_argument("--envs", type=int, default=16)
    p.add_argument("--frames", type=int, default=120)
    p.add_argument("--out", default="out/demo", help="folder for the demo's outputs")
    p.set_defaults(run=_demo)
    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
