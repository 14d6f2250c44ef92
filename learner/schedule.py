"""Annealing of the policy's learning rate and exploration noise over samples.

DeepMimic anneals its exploration over 64 M samples (``ExpAnnealSamples``); CleanRL anneals the
learning rate linearly to zero over the run's budget. Here both are linear in the samples
collected, from the config's value to a final one over a fixed number of samples and held
after it: the schedule does not depend on ``--samples``, so a run that is extended with
``--resume`` or given a larger budget learns exactly like a shorter one up to its end.
"""
from __future__ import annotations


def linear_anneal(start: float, final: float | None, samples: int, anneal_samples: int) -> float:
    """``start`` at 0 samples to ``final`` at ``anneal_samples``, held after; ``final=None`` keeps it constant."""
    if final is None or anneal_samples <= 0:
        return float(start) if final is None else float(final)
    progress = min(max(samples, 0) / anneal_samples, 1.0)
    return float(start + progress * (final - start))
