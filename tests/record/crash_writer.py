"""Child process of test_record_crash.py: records at 100 Hz until it is killed.

    python crash_writer.py BAG LOG

Message i on /PSM1/measured_js is a JointState whose content follows from i (expected(i));
every 10th i also goes to /PSM1/operating_state, and from i = 150 on /PSM1/jaw/measured_js
(a channel registered mid-recording). After write(i) returns, "i monotonic_ns" is appended to
LOG (unbuffered), so the parent knows what was handed to the writer and when.
"""
import sys
import time

from cressim.record import BagWriter
from cressim.record.schema import ARM_JOINTS

JS = "sensor_msgs/msg/JointState"


def expected(i):
    return {"header": {"stamp": {"sec": 1_700_000_000 + i // 100, "nanosec": (i % 100) * 10_000_000},
                       "frame_id": f"seq{i}"},
            "name": list(ARM_JOINTS), "position": [i * 1e-3 + j for j in range(6)],
            "velocity": [float(i)] * 6, "effort": [-float(i)] * 6}


def main(bag, log_path):
    writer = BagWriter(bag)  # defaults: 1 MiB / 1 s chunks, drop_oldest
    log = open(log_path, "w", buffering=1)
    start = time.monotonic()
    i = 0
    while True:
        writer.write("/PSM1/measured_js", expected(i), msgtype=JS)
        if i % 10 == 0:
            writer.write("/PSM1/operating_state",
                         {"state": "ENABLED", "is_homed": True, "header": {"frame_id": f"seq{i}"}},
                         msgtype="crtk_msgs/msg/OperatingState")
        if i >= 150:
            writer.write("/PSM1/jaw/measured_js", {"name": ["jaw"], "position": [i * 1e-3],
                                                   "header": {"frame_id": f"seq{i}"}}, msgtype=JS)
        log.write(f"{i} {time.monotonic_ns()}\n")
        i += 1
        delay = start + i * 0.01 - time.monotonic()
        if delay > 0:
            time.sleep(delay)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
