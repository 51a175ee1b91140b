"""`cressim record` and `cressim replay`.

Wiring into the `cressim` command (python/cressim/cli.py)::

    from cressim.record.cli import register
    register(sub)          # sub = parser.add_subparsers(...); adds "record" and "replay"

or, piecewise: ``add_record_arguments(p); p.set_defaults(run=record_main)`` (same for replay).
Standalone: ``python -m cressim.record record ...`` / ``python -m cressim.record replay ...``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .schema import DEFAULT_NAMESPACE, topics as schema_topics
from .writer import DEFAULT_CHUNK_SIZE, DEFAULT_MAX_CHUNK_AGE, ON_FULL


def add_record_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    p.description = ("Record the PSM topics (bags/README.md) to a rosbag2 MCAP bag over ROS 2, or a synthetic "
                     "session without ROS; repair a bag whose recorder crashed; summarise a bag.")
    p.add_argument("-o", "--output", help="bag directory to create (default: bags/psm_YYYYmmdd-HHMMSS)")
    p.add_argument("--ns", default=DEFAULT_NAMESPACE, help="arm namespace (default PSM1)")
    p.add_argument("--topics", nargs="+", metavar="TOPIC",
                   help="record only these (absolute, or relative to --ns); default: every schema topic")
    p.add_argument("--duration", type=float, help="stop after this many seconds (default: Ctrl-C)")
    p.add_argument("--chunk-size", type=int, default=DEFAULT_CHUNK_SIZE, help="close chunks at this many bytes")
    p.add_argument("--max-chunk-age", type=float, default=DEFAULT_MAX_CHUNK_AGE,
                   help="close chunks when their oldest message is this old (s): a crash loses at most this much")
    p.add_argument("--compression", default="zstd", choices=("zstd", "lz4", "none"))
    p.add_argument("--on-full", default="drop_oldest", choices=ON_FULL, help="queue policy when the disk lags")
    p.add_argument("--fsync", action="store_true", help="fsync every chunk (survives power loss, not only crashes)")
    p.add_argument("--best-effort", action="store_true", help="subscribe best effort (matches any publisher)")
    action = p.add_mutually_exclusive_group()
    action.add_argument("--recover", metavar="BAG", help="rebuild summary and metadata.yaml of a crashed recording")
    action.add_argument("--info", metavar="BAG", help="print a bag's topics, counts, duration and chunks")
    action.add_argument("--synthetic", type=float, metavar="SECONDS",
                        help="record a synthetic PSM session of this length (no ROS needed)")
    return p


def add_replay_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    p.description = ("Drive the twin from a bag's command topics (or a real robot's setpoint_js) with the recorded "
                     "timing, record the twin's response beside the bag and print tracking error per joint.")
    p.add_argument("bag", help="bag directory to replay")
    p.add_argument("--ns", default=DEFAULT_NAMESPACE, help="twin's arm namespace (default PSM1)")
    p.add_argument("--bag-ns", help="arm namespace in the bag (default: --ns)")
    p.add_argument("--out", help="bag for the twin's response (default: BAG_replay_YYYYmmdd-HHMMSS beside BAG)")
    p.add_argument("--no-record", action="store_true", help="do not record the response")
    p.add_argument("--rate", type=float, default=1.0, help="playback speed factor")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--from-setpoint", action="store_true", default=None,
                     help="replay setpoint_js as servo_jp (default when the bag has no position commands)")
    src.add_argument("--commands-only", dest="from_setpoint", action="store_false",
                     help="never use setpoint_js")
    p.add_argument("--topics", nargs="+", metavar="TOPIC", help="command topics to replay (relative to the ns)")
    p.add_argument("--no-state", action="store_true", help="do not replay state_command (enable, home, ...)")
    p.add_argument("--enable", type=float, metavar="SECONDS", nargs="?", const=2.0,
                   help="first send enable and home, then start the bag's commands this much later (default 2 s)")
    p.add_argument("--settle", type=float, default=0.5, help="seconds to keep measuring after the last command")
    p.add_argument("--hold", default="zoh", choices=("zoh", "linear"), help="reference between commands")
    p.add_argument("--loopback", action="store_true",
                   help="no ROS: replay into an in-process first-order model on simulated time (tests the "
                        "pipeline; the same result on any machine)")
    p.add_argument("--clock", default="wall", choices=("wall", "sim"),
                   help="time the commands and samples by the wall clock, or by the twin's /clock (simulated "
                        "time: a twin slowed by a busy machine gets each command at the same simulated time)")
    p.add_argument("--wait", type=float, default=10.0, help="seconds to wait for the twin's topics")
    p.add_argument("--json", metavar="FILE", help="also write the error tables as JSON")
    return p


def register(subparsers) -> None:
    """Add the `record` and `replay` subcommands to an argparse subparsers object."""
    p = subparsers.add_parser("record", help="record PSM topics to a rosbag2 MCAP bag; --recover, --info")
    add_record_arguments(p).set_defaults(run=record_main)
    p = subparsers.add_parser("replay", help="drive the twin from a bag and print tracking error per joint")
    add_replay_arguments(p).set_defaults(run=replay_main)


def _default_bag(prefix: str = "psm") -> str:
    return str(Path("bags") / f"{prefix}_{time.strftime('%Y%m%d-%H%M%S')}")


def _resolve_topics(args) -> dict[str, str]:
    table = schema_topics(args.ns)
    if not args.topics:
        return table
    out = {}
    by_rel = {t.split("/", 2)[-1] if t.startswith(f"/{args.ns.strip('/')}/") else t: (t, m) for t, m in table.items()}
    for name in args.topics:
        if name in table:
            out[name] = table[name]
        elif name in by_rel:
            topic, msgtype = by_rel[name]
            out[topic] = msgtype
        else:
            raise SystemExit(f"cressim record: {name} is not a schema topic (see bags/README.md)")
    return out


def record_main(args: argparse.Namespace) -> int:
    from .reader import bag_info, format_info

    if args.info:
        print(format_info(bag_info(args.info)))
        return 0
    if args.recover:
        from .recovery import recover

        report = recover(args.recover)
        if not report.repaired:
            print(f"{args.recover}: complete, nothing to recover")
            return 0
        print(f"recovered {report.messages} messages from {report.chunks_read} chunks into {report.file}")
        print(f"  stopped: {report.stop_reason}; {report.bytes_lost} bytes after the last good record")
        if report.original:
            print(f"  damaged original kept as {report.original}")
        for topic, count in sorted(report.topics.items()):
            print(f"  {topic:32s} {count:7d}")
        return 0
    output = args.output or _default_bag("synthetic" if args.synthetic is not None else "psm")
    if args.synthetic is not None:
        from .synthetic import record_synthetic

        record_synthetic(output, duration=args.synthetic, ns=args.ns)
        print(format_info(bag_info(output)))
        return 0

    from .ros import RclpyRecorder, rclpy_problem
    from .writer import BagWriter

    problem = rclpy_problem()
    if problem:
        print(f"cressim record: {problem}", file=sys.stderr)
        return 2
    topics = _resolve_topics(args)
    writer = BagWriter(output, chunk_size=args.chunk_size, max_chunk_age=args.max_chunk_age,
                       compression=args.compression, on_full=args.on_full, fsync=args.fsync)
    recorder = RclpyRecorder(writer, topics, ns=args.ns, best_effort=args.best_effort)
    for topic, why in recorder.skipped.items():
        print(f"  not recording {topic}: {why}", file=sys.stderr)
    print(f"recording {len(recorder.topics)} topics to {output} (Ctrl-C to stop)")
    start = time.monotonic()
    try:
        while args.duration is None or time.monotonic() - start < args.duration:
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        recorder.close()
        stats = writer.stats
        writer.close()
    print(f"stopped: {stats['accepted']} messages, {stats['dropped']} dropped, {recorder.errors} errors")
    print(format_info(bag_info(output)))
    return 0


def replay_main(args: argparse.Namespace) -> int:
    from .reader import read_messages
    from .replay import (LoopbackTwin, SimulatedClock, format_errors, load_commands, recorded_response, replay,
                         tracking_error)
    from .writer import BagWriter

    bag_ns = args.bag_ns or args.ns
    commands = load_commands(args.bag, ns=bag_ns, topics=args.topics, from_setpoint=args.from_setpoint,
                             state_commands=not args.no_state)
    if not commands:
        print(f"cressim replay: no command topics (or setpoint_js) under /{bag_ns.strip('/')} in {args.bag}",
              file=sys.stderr)
        return 2
    if args.enable is not None:
        from .replay import prepend_enable

        commands = prepend_enable(commands, args.enable)
    counts: dict[str, int] = {}
    for c in commands:
        counts[c.topic] = counts.get(c.topic, 0) + 1
    print(f"replaying {len(commands)} commands over {commands[-1].t / args.rate:.2f} s: "
          + ", ".join(f"{t} x{n}" for t, n in sorted(counts.items())))

    out = None
    recorder = None
    if not args.no_record:
        bag = Path(args.bag)
        out = args.out or str(bag.parent / f"{bag.name}_replay_{time.strftime('%Y%m%d-%H%M%S')}")
        recorder = BagWriter(out, custom_data={"replay_of": str(bag.resolve()), "rate": str(args.rate)})

    link = None
    try:
        sleep = time.sleep
        if args.loopback:  # the stand-in twin and the replay on simulated time: the same on any machine
            sim = SimulatedClock()
            link = LoopbackTwin(recorder=recorder, ns=args.ns, clock=sim)
            publish = _recording_publish(link.publish, recorder, args.ns)
            sleep = sim.sleep
        else:
            from .ros import RclpyTwinLink, rclpy_problem

            problem = rclpy_problem()
            if problem:
                print(f"cressim replay: {problem} (or use --loopback)", file=sys.stderr)
                return 2
            types = {c.topic: c.msgtype for c in commands}
            link = RclpyTwinLink(types, ns=args.ns, recorder=recorder, sim_clock=args.clock == "sim")
            missing = link.wait_for_twin(args.wait)
            if missing:
                print("cressim replay: the twin is not there: " + ", ".join(missing), file=sys.stderr)
                return 3
            link.drain()
            publish = link.publish
        result = replay(commands, publish, link, rate=args.rate, settle=args.settle, clock=link.clock, sleep=sleep)
    finally:
        if link is not None and hasattr(link, "close"):
            link.close()
        if recorder is not None:
            recorder.close()

    print(f"published {len(result.commands)} commands in {result.wall_s:.2f} s (worst lateness "
          f"{result.max_lateness * 1e3:.1f} ms); measured samples: "
          + ", ".join(f"{'/'.join(g) if len(g) == 1 else 'arm'} {len(v)}" for g, v in result.measured.items()))
    tables = {"tracking": tracking_error(result.reference(), result.measured, hold=args.hold)}
    print(format_errors(tables["tracking"], "tracking error, twin measured - commanded (rad; m for insertion)"))
    has_measured = any(True for _ in read_messages(args.bag, f"/{bag_ns.strip('/')}/measured_js"))
    if has_measured:
        real = recorded_response(args.bag, commands, ns=bag_ns)
        tables["sim_vs_recorded"] = tracking_error(real, result.measured, hold="linear")
        print(format_errors(tables["sim_vs_recorded"], "sim vs recorded, twin measured - bag measured_js"))
    if out:
        print(f"twin response recorded to {out}")
    if args.json:
        Path(args.json).write_text(json.dumps({"bag": args.bag, "response": out, "errors": tables}, indent=2))
    return 0


def _recording_publish(publish, recorder, ns):
    """Wrap an in-process publish so the commands sent land in the response bag too."""
    if recorder is None:
        return publish

    def wrapped(topic, msgtype, data):
        recorder.write(topic if topic.startswith("/") else f"/{ns.strip('/')}/{topic}", data, msgtype=msgtype)
        publish(topic, msgtype, data)
    return wrapped


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cressim.record")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.run(args)


__all__ = ["add_record_arguments", "add_replay_arguments", "main", "record_main", "register", "replay_main"]
