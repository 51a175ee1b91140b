"""Sensor outputs on the host: PNG export of ultrasound layers (the PNG writer is cressim.io's)."""
from .ultrasound import save_ultrasound_png

__all__ = ["save_ultrasound_png"]
