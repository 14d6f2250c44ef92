"""Re-export of the user-facing error type for services/ code."""
from actors.errors import MotionFormatError, SfvError

__all__ = ["SfvError", "MotionFormatError"]
