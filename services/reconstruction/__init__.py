"""Motion reconstruction (SFV section 6): a video's pose track -> a humanoid ReferenceMotion.

    motion = reconstruct_track(track)            # in this process
    motion = reconstruct_on_ray(track, config)   # as a Ray task

Names are resolved lazily, so `sfv --help` (which imports every command module) does not
import torch through this package.
"""
from importlib import import_module

_EXPORTS = {
    "ReconstructionConfig": "services.reconstruction.config",
    "reconstruct_on_ray": "services.reconstruction.distributed",
    "reconstruct_task": "services.reconstruction.distributed",
    "JOINT_KEYPOINTS": "services.reconstruction.keypoints",
    "reconstruct_track": "services.reconstruction.reconstruct",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'services.reconstruction' has no attribute {name!r}")
