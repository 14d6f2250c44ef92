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


def decaying_help(final: float, samples: int, total: int, window: tuple[float, float] = (0.25, 0.75)) -> float:
    """A help's strength (the residual root wrench's, `TrainConfig.residual_force_final`): 1 until
    ``window[0]`` of the run's ``total`` samples, linear to ``final`` by ``window[1]``, held after.
    Unlike the schedules above it follows the run's budget: the last part of every run must train
    at the final strength."""
    first, last = int(window[0] * total), int(window[1] * total)
    return linear_anneal(1.0, float(final), samples - first, last - first)


# rsl_rl's bounds are 1e-5 .. 1e-2 for 256-unit nets; the 1024-512 nets here move far more per
# step at the same rate, so both bounds sit an order of magnitude lower.
ADAPTIVE_LR_MIN = 1e-6
ADAPTIVE_LR_MAX = 1e-3
ADAPTIVE_LR_FACTOR = 1.5


def adapt_rate_to_kl(lr: float, kl: float, desired_kl: float) -> float:
    """The adaptive-KL rule of rsl_rl and ProtoMotions, applied after each minibatch: the
    learning rate shrinks by 1.5x when the policy moved more than twice ``desired_kl`` away from
    the one that collected the batch, and grows by 1.5x when it moved less than half of it.
    The step size then follows the policy's actual change instead of a fixed guess."""
    if kl > 2.0 * desired_kl:
        lr /= ADAPTIVE_LR_FACTOR
    elif kl < 0.5 * desired_kl:
        lr *= ADAPTIVE_LR_FACTOR
    return float(min(max(lr, ADAPTIVE_LR_MIN), ADAPTIVE_LR_MAX))
