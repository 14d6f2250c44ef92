"""The terms of SFV's reconstruction loss (section 6), per frame, in torch.

    l_rec = w2D l2D + w3D l3D + wsm lsm
    l2D = sum_t sum_j c_tj |x_tj - Pi(F_j(q_t))|_1
    l3D = sum_t w_t sum_k dist(q_hat_tk, q_tk),   w_t = exp(-delta_t)
    lsm = sum_t sum_j |F_j(q_t) - F_j(q_t+1)|^2

and, where the foot-contact estimator says a foot is down (SFV section 6 asks the motion to be
one a physics character can follow; movingcam's contact reward and PhysCap's foot constraints
are the same idea), two contact terms and the no-penetration term:

    lcontact = sum_t sum_f c_tf (z_tf - g)^2          z_tf the foot's lowest point, g the ground
    lslide   = sum_t sum_f c_tf c_t+1,f rho(|p_t+1,f - p_tf|_xy)   p the foot's centre, rho Charbonnier
    lground  = sum_t sum_corners relu(g - z)^2

2D residuals are in image units (per mille of the image height by default,
`ReconstructionConfig.image_unit`), joint positions in a length unit (centimetres,
`ReconstructionConfig.length_unit_m`), rotations in radians. The functions return one value per frame
(or frame pair); the caller averages over frames, so the balance between the terms does not
depend on the clip's length.
"""
from __future__ import annotations

import torch

from services.reconstruction import quaternion_torch as qt


def reprojection_l1(projected: torch.Tensor, observed: torch.Tensor, weight: torch.Tensor, px_to_unit: float) -> torch.Tensor:
    """(T,) sum over points of weight * L1 distance, in image units.
    projected, observed: (T, P, 2) pixels; weight: (T, P) confidence times point weight;
    px_to_unit: image units per pixel."""
    return (weight * (projected - observed).abs().sum(-1)).sum(-1) * px_to_unit


def reprojection_error(projected, observed, weight, px_to_unit: float):
    """(T,) weighted mean Euclidean reprojection error in image units (delta_t before scaling);
    zero on frames whose weights are all zero."""
    distance = (projected - observed).norm(dim=-1)
    total = weight.sum(-1)
    return (weight * distance).sum(-1) / total.clamp_min(1e-9) * px_to_unit


def rotation_distance(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Angle (radians) of the rotation taking a to b, for unit quaternions (..., 4)."""
    return qt.quat_angle(qt.quat_mul(qt.quat_conj(a), b))


def prediction_consistency(rotations: torch.Tensor, predicted: torch.Tensor, frame_weight: torch.Tensor) -> torch.Tensor:
    """(T,) w_t * sum_k dist(q_hat_tk, q_tk) over the rotations (T, K, 4) (root and joints)."""
    return frame_weight * rotation_distance(predicted, rotations).sum(-1)


def smoothness(points: torch.Tensor, unit_m: float) -> torch.Tensor:
    """(T-1,) sum over joints of the squared displacement between adjacent frames, in length units^2."""
    step = (points[1:] - points[:-1]) / unit_m
    return (step * step).sum((-1, -2))


def ground_penetration(foot_corners: torch.Tensor, unit_m: float, ground=0.0) -> torch.Tensor:
    """(T,) sum of squared depths (length units) of foot corners (T, ..., 3) below z = ground."""
    below = torch.relu(ground - foot_corners[..., 2]) / unit_m
    return (below * below).flatten(1).sum(-1)


def contact_height(foot_corners: torch.Tensor, contacts: torch.Tensor, unit_m: float, ground=0.0) -> torch.Tensor:
    """(T,) sum over the feet in contact (contacts (T, F) 0/1) of the squared height (length
    units) of the foot's lowest corner above the ground (or below it); foot_corners (T, F, C, 3)."""
    height = (foot_corners[..., 2].min(dim=-1).values - ground) / unit_m
    return (contacts * height * height).sum(-1)


def contact_sliding(foot_corners: torch.Tensor, contacts: torch.Tensor, unit_m: float, smooth: float = 0.1) -> torch.Tensor:
    """(T-1,) sum over the feet in contact at both ends of a frame pair of the horizontal step
    (length units) of the foot's centre (the mean of its corners (T, F, C, 3)), as the
    Charbonnier sqrt(step^2 + smooth^2) - smooth: near zero it pins the foot as an L1 term does,
    and a foot the estimator calls down while it swings pays linearly, not quadratically."""
    centre = foot_corners[..., :2].mean(dim=-2) / unit_m
    step = centre[1:] - centre[:-1]
    held = contacts[1:] * contacts[:-1]
    return (held * ((step * step).sum(-1) + smooth * smooth).sqrt() - held * smooth).sum(-1)
