"""Domain randomization: per-env physical, visual and sensor parameters drawn on the GPU at reset
or on an interval, from a config in a task or a scene file (docs/envs.md, "Domain randomization")."""
from .config import PARAMS, Param, RandomizationError, Term, file_randomization, load_terms, parse_terms
from .randomizer import Randomizer

__all__ = ["PARAMS", "Param", "RandomizationError", "Randomizer", "Term", "file_randomization", "load_terms", "parse_terms"]
