"""Differentiable torch mirror of `actors.character.quaternion` (w, x, y, z), for motion reconstruction."""
from __future__ import annotations

import torch

from actors.character.quaternion import hamilton_product


def quat_mul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return torch.stack(hamilton_product(a.unbind(-1), b.unbind(-1)), dim=-1)


def quat_conj(q: torch.Tensor) -> torch.Tensor:
    return q * q.new_tensor([1.0, -1.0, -1.0, -1.0])


def quat_normalize(q: torch.Tensor, eps: float = 1e-12) -> torch.Tensor:
    return q / q.norm(dim=-1, keepdim=True).clamp_min(eps)


def quat_rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    w = q[..., :1]
    u = q[..., 1:]
    u, v = torch.broadcast_tensors(u, v)
    t = 2.0 * torch.linalg.cross(u, v, dim=-1)
    return v + w * t + torch.linalg.cross(u, t, dim=-1)


def quat_from_axis_angle(rotvec: torch.Tensor) -> torch.Tensor:
    """Exponential map with a smooth gradient at zero (series for small angles)."""
    angle_sq = (rotvec * rotvec).sum(-1, keepdim=True)
    small = angle_sq < 1e-8
    angle = torch.sqrt(torch.where(small, torch.ones_like(angle_sq), angle_sq))
    scale = torch.where(small, 0.5 - angle_sq / 48.0, torch.sin(0.5 * angle) / angle)
    w = torch.where(small, 1.0 - angle_sq / 8.0, torch.cos(0.5 * angle))
    return torch.cat((w, rotvec * scale), dim=-1)


def quat_about_axis(angle: torch.Tensor, axis: torch.Tensor) -> torch.Tensor:
    half = 0.5 * angle.unsqueeze(-1)
    return torch.cat((torch.cos(half), torch.sin(half) * axis), dim=-1)


def quat_angle(q: torch.Tensor, eps: float = 1e-9) -> torch.Tensor:
    """Rotation angle in [0, pi]; eps keeps the gradient finite at the identity."""
    return 2.0 * torch.atan2(torch.sqrt((q[..., 1:] ** 2).sum(-1) + eps), q[..., 0].abs())
