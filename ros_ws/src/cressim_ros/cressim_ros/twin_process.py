"""The twin as a subprocess (a DDS participant of its own): for tests and the demo."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

PKG = Path(__file__).resolve().parents[1]  # ros_ws/src/cressim_ros (or its install)
REPO = Path(__file__).resolve().parents[4] if (Path(__file__).resolve().parents[4] / "ros_ws").is_dir() else Path.cwd()
# s: torch, rclpy, the engine and its first frame on lavapipe (about 5 s when the machine is idle and
# the driver's shader cache warm; a minute or more cold on 2 busy cores). A safety net only: the
# twin says "ready" when its first tick is out.
STARTUP_TIMEOUT = 600.0
# s: a clean shutdown (the sensor thread's last frame, the recording's last chunk); on a loaded
# machine it takes seconds. A safety net only, before SIGKILL.
STOP_TIMEOUT = 120.0


class Twin:
    """A twin node in a subprocess; `stop()` sends SIGINT and returns its exit code."""

    def __init__(self, domain: int, log_path: Path, *params: str, params_file: str | None = None):
        self.domain, self.log_path = domain, log_path
        env = dict(os.environ)
        env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                   PYTHONPATH=os.pathsep.join([str(PKG), env.get("PYTHONPATH", "")]), PYTHONUNBUFFERED="1")
        env.pop("ROS_LOCALHOST_ONLY", None)
        args = [sys.executable, "-m", "cressim_ros", "--ros-args"]
        if params_file:
            args += ["--params-file", str(params_file)]
        for p in params:
            args += ["-p", p]
        self.log = open(log_path, "w")
        self.proc = subprocess.Popen(args, cwd=REPO, env=env, stdout=self.log, stderr=subprocess.STDOUT)
        self.started = time.monotonic()

    def output(self) -> str:
        if not self.log.closed:
            self.log.flush()
        return self.log_path.read_text()

    def wait_ready(self, timeout: float = STARTUP_TIMEOUT):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if "cressim twin ready" in self.output():
                return time.monotonic() - self.started
            if self.proc.poll() is not None:
                raise RuntimeError(f"twin exited with {self.proc.returncode}:\n{self.output()}")
            time.sleep(0.1)
        raise RuntimeError(f"twin not ready after {timeout} s:\n{self.output()}")

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()
        return self.proc.returncode
