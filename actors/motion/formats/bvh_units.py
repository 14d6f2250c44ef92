"""The axes and length units a BVH file may use (BVH names neither; `retarget.py` detects them).

Kept apart from the retargeter so that the command line can list them without importing it
(and, through the humanoid's kinematics, torch: `sfv eval --onnx` runs without torch).
"""
from __future__ import annotations

UNIT_METRES = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
AXES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1)}
