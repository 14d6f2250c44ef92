"""Crash-safe writes for checkpoints and exports (the project-wide helper in actors/)."""
from actors.atomic_file import TEMP_SUFFIX, atomic_output, atomic_write_bytes

__all__ = ["TEMP_SUFFIX", "atomic_output", "atomic_write_bytes"]
