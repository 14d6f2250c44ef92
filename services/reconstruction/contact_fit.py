"""The ground under the feet the foot-contact estimator says are down.

Without contacts, the ground goes under a low percentile of each frame's lowest foot point
and the motion is lifted so that its lowest point of the clip touches it: every other frame
then floats (cam01: contact feet 2-12 cm up, a start state that drops the character). With
contacts, the ground height is a free parameter of the optimisation, started at the median
lowest point of the contact feet, and the contact terms (`losses.contact_height`,
`losses.contact_sliding`) pull those feet onto it and hold them there. Afterwards a frame
whose foot still dips below the ground (the penetration term is soft) has its root lifted by
the depth, so no frame penetrates.

Feet on the floor do not make a reference that stands: the static-balance term
(`losses.static_balance`, weight `w_balance`) also holds the whole-body centre of mass (the
humanoid's link masses through the same forward kinematics, `body.centre_of_mass`) within
`balance_margin_m` of the contact feet's support in every frame with a foot down. It needs
these contacts (a fitted ground), so it is off wherever they are.
"""
from __future__ import annotations

import numpy as np
import torch

GROUND_PERCENTILE = 10.0  # of the per-frame lowest foot point, placed on the ground when no contacts are known


def lowest_foot_points(corners: np.ndarray) -> np.ndarray:
    """(T, F) lowest z of each foot from its box corners (T, F, C, 3)."""
    return corners[..., 2].min(axis=-1)


def initial_ground(corners: np.ndarray, contacts: np.ndarray | None) -> float:
    """Ground height under the initial poses: the median lowest point of the contact feet, or
    (no contact known) a low percentile of each frame's lowest foot point."""
    lowest = lowest_foot_points(corners)
    if contacts is not None and contacts.any():
        return float(np.median(lowest[contacts]))
    return float(np.percentile(lowest.min(axis=1), GROUND_PERCENTILE))


def ground_parameter(fitted: bool, dtype: torch.dtype) -> torch.Tensor:
    """The ground height (1,) relative to the initial ground: a leaf when fitted, else a constant 0."""
    return torch.zeros(1, dtype=dtype, requires_grad=fitted)


def lift_out_of_ground(corners: np.ndarray) -> np.ndarray:
    """(T,) how far each frame must rise so that no foot corner (T, F, C, 3) is below z = 0."""
    return np.maximum(0.0, -corners[..., 2].reshape(len(corners), -1).min(axis=1))
