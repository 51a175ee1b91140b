#!/usr/bin/env python3
"""Regenerate the sample recording bags/psm1_sample (deterministic; see bags/README.md).

    .venv/bin/python bags/make_sample.py [OUT_DIR]

A 4 s synthetic PSM1 session (cressim.record.synthetic): enable + home, then servo_jp /
jaw/servo_jp at 100 Hz with the arm following through a first-order lag; setpoint and measured
joint states, tool-tip poses (DH forward kinematics) and tf. Written by the same BagWriter the
recorder uses, with 64 KiB chunks so that the sample holds several zstd chunks.
"""
import shutil
import sys
from pathlib import Path

from cressim.record.reader import bag_info, format_info
from cressim.record.synthetic import record_synthetic

SAMPLE = Path(__file__).resolve().parent / "psm1_sample"
DURATION = 4.0
CHUNK_SIZE = 64 << 10


def make(out: Path = SAMPLE) -> Path:
    out = Path(out)
    if out.exists():
        shutil.rmtree(out)
    record_synthetic(out, duration=DURATION, chunk_size=CHUNK_SIZE)
    return out


if __name__ == "__main__":
    path = make(Path(sys.argv[1]) if len(sys.argv) > 1 else SAMPLE)
    print(format_info(bag_info(path)))
