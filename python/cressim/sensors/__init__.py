"""Sensor outputs on the host: PNG export of images (ultrasound layers, camera images)."""
from .png import write_png
from .ultrasound import save_ultrasound_png

__all__ = ["save_ultrasound_png", "write_png"]
