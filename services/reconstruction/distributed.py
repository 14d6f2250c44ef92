"""Reconstruction as a Ray task (one CPU; torch then runs single-threaded inside it)."""
from __future__ import annotations

from actors.motion.reference_motion import ReferenceMotion
from services.ray_session import get_results, ray_session
from services.reconstruction.config import ReconstructionConfig
from services.reconstruction.reconstruct import reconstruct_track


def reconstruct_task():
    """The `ray.remote` version of `reconstruct_track` (built on first use, so importing this
    module does not import Ray)."""
    import ray

    return ray.remote(num_cpus=1, max_retries=0)(reconstruct_track)


def reconstruct_on_ray(track, config: ReconstructionConfig | None = None, name: str = "reconstruction",
                       contact_estimate=None) -> ReferenceMotion:
    """Run `reconstruct_track` as a Ray task and wait for it. Uses the running Ray when there
    is one; otherwise starts a local one and shuts it down afterwards."""
    with ray_session():
        return get_results(reconstruct_task().remote(track, config or ReconstructionConfig(), name, contact_estimate))
