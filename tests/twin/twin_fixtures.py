"""A twin shared by a test module (teardown registered with pytest's request); an in-process twin
node spun beside a client node; where the dVRK's own Python clients are, the environment a script
of theirs runs in, and the runner that starts one."""
import contextlib
import os
import re
import subprocess
import sys
import threading
from pathlib import Path

from cressim_ros.twin_process import Twin

REPO = Path(__file__).resolve().parents[2]


# Twins in tests render small images at 2 Hz (lavapipe renders on the test machine's CPU); a test's own
# camera_* parameters come later on the command line and win.
TEST_CAMERA = ("camera_width:=64", "camera_height:=48", "camera_rate:=2.0")


# "Keeps publishing" is counted in ticks, never in Hz: on 2 loaded cores lavapipe, DDS and the
# client share the CPU and the rate is whatever the machine gives (rates are benchmarks' business).
def keeps_publishing(arm, ticks: int = 50, timeout: float = 120.0) -> bool:
    """measured_js keeps coming: `ticks` more messages (one per tick, however slowly the machine
    runs the twin; the timeout only catches a stalled twin)."""
    return arm.wait_measured(ticks, timeout=timeout)


@contextlib.contextmanager
def spinning(node, client_name: str, executor_class=None):
    """A client node on the twin node's context, both spun by one executor (default: single
    threaded, as the twin's own main) on a thread of its own; yields the client node."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    client = rclpy.create_node(client_name, context=node.context)
    executor = (executor_class or SingleThreadedExecutor)(context=node.context)
    executor.add_node(node)
    executor.add_node(client)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        yield client
    finally:
        executor.shutdown()
        spinner.join(timeout=30)
        client.destroy_node()


class OwnContextClient:
    """A client node in an rclpy context (a DDS participant) of its own on `domain`, with a
    condition for what its callbacks keep; `start()` spins it on a thread once the subclass has
    made its endpoints, `close()` ends it."""

    def __init__(self, domain: int, name: str):
        import rclpy
        from rclpy.context import Context

        self.rclpy = rclpy
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = rclpy.create_node(name, context=self.context)
        self.cv = threading.Condition()

    def start(self):
        from rclpy.executors import SingleThreadedExecutor

        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.running = True
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self):
        while self.running and self.context.ok():
            self.executor.spin_once(timeout_sec=0.05)

    def close(self):
        self.running = False
        self.thread.join(timeout=10)
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.try_shutdown(context=self.context)


def module_twin(request, tmp_path_factory, domain, *params):
    twin = Twin(domain, tmp_path_factory.mktemp("twin") / "twin.log", *TEST_CAMERA, *params)
    request.addfinalizer(twin.stop)
    twin.startup_s = twin.wait_ready()
    return twin


def clients_folder() -> Path:
    """The dVRK's Python clients (shared/third_party/README.md): $CRESSIM_DVRK_CLIENTS (relative to
    the repository root) or ../shared/third_party."""
    value = os.environ.get("CRESSIM_DVRK_CLIENTS")
    return (REPO / value).resolve() if value else (REPO.parent / "shared" / "third_party").resolve()


def script_env(clients: Path, domain: int) -> dict:
    """A client script's environment: crtk and dvrk on PYTHONPATH before ROS's, ROS 2, the twin's
    domain on loopback."""
    env = dict(os.environ)
    paths = [str(clients / "crtk_python_client" / "src"), str(clients / "dvrk_python" / "src")]
    env.update(PYTHONPATH=os.pathsep.join(paths + [p for p in [env.get("PYTHONPATH")] if p]),
               ROS_VERSION="2", ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               PYTHONUNBUFFERED="1", CRESSIM_DVRK_CLIENTS=str(clients))
    env.pop("ROS_LOCALHOST_ONLY", None)
    env.pop("ROS_STATIC_PEERS", None)
    return env


# crtk's ral.shutdown() (crtk_python_client/src/crtk/ral_ros2.py) calls rclpy.shutdown() before it
# joins its spin thread: when the thread is between two waits at that moment, it dies with an
# rclpy error (seen: "failed to initialize wait set: the given context is not valid") while the
# script exits with status 0. A race in the client at exit, on the real dVRK too, that says nothing
# about the twin: the spin thread's traceback is dropped where it is the output's last thing; any
# other traceback, or one followed by more output, still counts.
CLIENT_EXIT_RACE = re.compile(
    r"^Exception in thread [^\n]*\(_try_spin\):\n(?:Traceback[^\n]*\n|[ \t][^\n]*\n)*?"
    r"rclpy\._rclpy_pybind11\.(?:RCLError|InvalidHandle): [^\n]*\s*\Z", re.M)

NEWLINES = "\n" * 200  # a script's stdin: Enter, as often as it asks (dvrk_psm_test.py waits for it)


class ScriptRun:
    """One of the dVRK's Python clients (or `-c code`) running as a subprocess against the twin of
    `domain`, as a dVRK user runs it: script_env's environment, stdin a stream of newlines,
    stdout and stderr together into `cwd`/script.log. `wait` for a script that ends by itself;
    `stop` (or the `with` block's end) for one that runs until stopped."""

    def __init__(self, clients: Path, domain: int, args: list[str], cwd: Path):
        self.log = Path(cwd) / "script.log"
        with open(self.log, "w") as out:
            self.proc = subprocess.Popen([sys.executable, *map(str, args)], stdin=subprocess.PIPE, stdout=out,
                                         stderr=subprocess.STDOUT, text=True, env=script_env(clients, domain), cwd=cwd)
        try:
            self.proc.stdin.write(NEWLINES)
            self.proc.stdin.close()
        except BrokenPipeError:
            pass  # it exited already: its output says why

    def output(self) -> str:
        return self.log.read_text()

    def output_after_exit_race(self) -> str:
        """The output without crtk's spin thread's traceback at exit (CLIENT_EXIT_RACE)."""
        return CLIENT_EXIT_RACE.sub("", self.output())

    def running(self) -> bool:
        return self.proc.poll() is None

    def wait(self, limit: float) -> int | None:
        """Its exit status, or None when it was still running after `limit` s (a safety limit
        that only catches a hang: it is killed and the output says so)."""
        try:
            return self.proc.wait(timeout=limit)
        except subprocess.TimeoutExpired:
            self.stop()
            with open(self.log, "a") as out:
                out.write(f"\n[killed after the {limit:.0f} s safety limit]")
            return None

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
