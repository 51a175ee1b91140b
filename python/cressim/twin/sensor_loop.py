"""The twin's sensors on their own cadence, off the control tick.

The control tick (TwinArms.tick, 100 Hz) never waits on an image: each tick tells the loop the
simulated time (`offer`), and a sensor whose period has come is rendered by a worker thread:
the engine frame (for a kinematic arm, its links posed at that tick's measured joints), the
read of its outputs to the host, then the caller's `publish`. When the worker is still busy
with an earlier frame, the due frame is skipped and counted (frames fall on ticks, at most at
their rate, never in a burst after a slow spell). A dynamic arm's physics and a sensor frame
share the engine through `arms.engine_lock`.

`threaded=False` renders inline in `offer` (in-process tests that tick by hand, and a GPU where a
frame costs less than a tick).

On a CPU device (lavapipe) rendering and the tick share the cores: `lower_priority` gives the
worker and the driver's threads a lower scheduling priority (Linux nice), so a frame takes the
time the tick leaves and not the other way round.
"""
from __future__ import annotations

import os
import threading
from dataclasses import dataclass
from typing import Callable


@dataclass
class Sensor:
    """One sensor group the loop renders: `rate` Hz in simulated time; `render` (cameras) and/or
    `sense` (simulation sensors, e.g. ultrasound); `read()` -> host data, called with the engine
    lock held right after the frame; `publish(data, stamp)` called after the lock is released."""
    name: str
    rate: float
    read: Callable
    publish: Callable
    render: bool = False
    sense: bool = False
    enabled: bool = True
    next_ns: int = 0  # 0: due at the next offer
    rendered: int = 0
    skipped: int = 0


class SensorLoop:
    def __init__(self, arms, sensors: list[Sensor], *, threaded: bool = True, on_error=None):
        self.arms, self.sensors = arms, {s.name: s for s in sensors}
        self.threaded = threaded
        self.on_error = on_error or (lambda sensor, exc: None)
        self._work = None  # (sensors, stamp) handed to the worker
        self._cv = threading.Condition()
        self._stop = False
        self._busy = False
        self._thread = None
        self.niceness = 0
        if threaded:
            self._thread = threading.Thread(target=self._run, name="cressim-sensors", daemon=True)
            self._thread.start()

    def set_rate(self, name: str, rate: float):
        self.sensors[name].rate = rate

    def enable(self, name: str, on: bool):
        if name in self.sensors:
            self.sensors[name].enabled = on

    def _due(self, s: Sensor, sim_ns: int) -> bool:
        if not s.enabled or sim_ns < s.next_ns:
            return False
        period = int(round(1e9 / s.rate))
        nxt = (s.next_ns or sim_ns) + period
        s.next_ns = nxt if nxt > sim_ns else sim_ns + period
        return True

    def rewind(self):
        """The simulated clock went back (a restart): every sensor is due at the next offer."""
        for s in self.sensors.values():
            s.next_ns = 0

    def offer(self, sim_ns: int, stamp) -> list[str]:
        """Called by each tick after TwinArms.tick: hands the sensors due at sim_ns (stamped
        `stamp`) to the worker, or renders them here when not threaded. Returns their names."""
        due = [s for s in self.sensors.values() if self._due(s, sim_ns)]
        if not due:
            return []
        if not self.threaded:
            self._frame(due, stamp)
            return [s.name for s in due]
        with self._cv:
            if self._busy or self._work is not None:
                for s in due:
                    s.skipped += 1  # late: the worker is still on an earlier frame
                return []
            self._work = (due, stamp)
            self._cv.notify()
        return [s.name for s in due]

    def render_now(self, stamp=None, names=None):
        """One frame of the given (default: all enabled) sensors on the calling thread, waited
        for: builds every pipeline before the twin reports ready."""
        sensors = [s for s in self.sensors.values() if s.enabled and (names is None or s.name in names)]
        if sensors:
            self._frame(sensors, stamp)

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Waits until the worker has no frame (for tests and shutdown)."""
        with self._cv:
            return self._cv.wait_for(lambda: not self._busy and self._work is None, timeout)

    def _frame(self, sensors, stamp):
        arms = self.arms
        with arms.engine_lock:
            arms.step_engine(render=any(s.render for s in sensors), sense=any(s.sense for s in sensors))
            data = []
            for s in sensors:
                try:
                    data.append(s.read())
                except Exception as exc:  # noqa: BLE001 - a sensor failure must not stop the others
                    data.append(exc)
        for s, d in zip(sensors, data):
            try:
                if isinstance(d, Exception):
                    raise d
                if stamp is not None:
                    s.publish(d, stamp)
                s.rendered += 1
            except Exception as exc:  # noqa: BLE001
                self.on_error(s, exc)

    def _run(self):
        if self.niceness:
            _renice([threading.get_native_id()], self.niceness)
        while True:
            with self._cv:
                self._cv.wait_for(lambda: self._stop or self._work is not None)
                if self._stop:
                    return
                (sensors, stamp), self._work = self._work, None
                self._busy = True
            try:
                self._frame(sensors, stamp)
            except Exception as exc:  # noqa: BLE001 - the loop goes on with the next frame
                self.on_error(None, exc)
            finally:
                with self._cv:
                    self._busy = False
                    self._cv.notify_all()

    def lower_priority(self, threads, niceness: int = 10):
        """Lowers the scheduling priority of the worker and of `threads` (native thread ids, e.g.
        the Vulkan driver's rasterizer threads) by `niceness`. Linux only; a no-op elsewhere."""
        self.niceness = niceness
        ids = list(threads) + ([self._thread.native_id] if self._thread is not None and self._thread.native_id else [])
        _renice(ids, niceness)

    def close(self):
        if self._thread is not None:
            with self._cv:
                self._stop = True
                self._cv.notify_all()
            self._thread.join(timeout=30)
            self._thread = None

    def stats(self) -> dict:
        return {name: dict(rendered=s.rendered, skipped=s.skipped, rate=s.rate, enabled=s.enabled)
                for name, s in self.sensors.items()}


def process_threads() -> set[int]:
    """Native ids of this process's threads (Linux; empty elsewhere)."""
    try:
        return {int(t) for t in os.listdir("/proc/self/task")}
    except OSError:
        return set()


def _renice(ids, niceness: int):
    for tid in ids:
        try:
            os.setpriority(os.PRIO_PROCESS, tid, max(os.getpriority(os.PRIO_PROCESS, tid), niceness))
        except (OSError, AttributeError):
            pass  # gone, or not Linux


__all__ = ["Sensor", "SensorLoop", "process_threads"]
