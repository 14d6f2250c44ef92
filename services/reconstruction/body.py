"""The humanoid's pose as free parameters, and the points the losses read from it.

A pose trajectory is the root position (T, 3), the root rotation as a base quaternion times
the exponential map of a free rotation vector (T, 3), the 8 spherical joints' rotation
vectors (T, 8, 3) and the 4 hinge angles (T, 4). Joint limits are per axis of these
exponential coordinates (`skeleton.joint_limits_zup`, the box MuJoCo's actuators use), so
keeping a joint in its limits is a clamp of its parameters.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from actors.character.skeleton import (
    HINGE_AXIS,
    JOINT_LINKS,
    LINK_NAMES,
    LINKS,
    NUM_LINKS,
    REVOLUTE_JOINTS,
    SPHERICAL_JOINTS,
    TOTAL_MASS,
    joint_limits_zup,
    yup_to_zup,
)
from services.reconstruction import quaternion_torch as qt
from services.reconstruction.batched_kinematics import link_frames
from services.reconstruction.keypoints import FIT_LINKS, FIT_OFFSETS, FOOT_CENTRE, FOOT_HALF, NUM_FIT

SPHERICAL_LIMITS = np.stack([joint_limits_zup(LINKS[JOINT_LINKS[j]]) for j in SPHERICAL_JOINTS])  # (8, 3, 2)
REVOLUTE_LIMITS = np.concatenate([joint_limits_zup(LINKS[JOINT_LINKS[j]]) for j in REVOLUTE_JOINTS])  # (4, 2)
# cat(spherical, revolute) position of each joint in skeleton order.
_JOINT_ORDER = torch.as_tensor(np.argsort(np.concatenate((SPHERICAL_JOINTS, REVOLUTE_JOINTS))))
FOOT_LINKS = np.array([LINK_NAMES.index("right_ankle"), LINK_NAMES.index("left_ankle")])
# Each link's centre of mass in its frame and its share of the body's mass: the humanoid MJCF
# (`actors/character/humanoid.py`) gives every body one geom of the link's mass centred there,
# so MuJoCo's body centre of mass is that geom's centre (a test checks the whole-body CoM
# against MuJoCo's subtree_com).
LINK_COM_OFFSETS = np.stack([yup_to_zup(link.geom_offset_yup) for link in LINKS])  # (15, 3), Z-up
LINK_MASS_FRACTIONS = np.array([link.mass for link in LINKS]) / TOTAL_MASS  # (15,), sums to 1
# The 8 corners of the foot box in the ankle frame: the lowest of them is the foot's lowest point.
FOOT_CORNERS = FOOT_CENTRE + FOOT_HALF * np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
SOLE_CORNERS = np.array([i for i, corner in enumerate(FOOT_CORNERS) if corner[2] < FOOT_CENTRE[2]])  # the box's bottom face


@dataclass
class PoseParams:
    """Leaf tensors of a pose trajectory; `root_base` is a constant."""

    root_pos: torch.Tensor  # (T, 3)
    root_base: torch.Tensor  # (T, 4) unit quaternions, not optimised
    root_rotvec: torch.Tensor  # (T, 3) rotation applied after root_base (in the root frame)
    spherical: torch.Tensor  # (T, 8, 3)
    revolute: torch.Tensor  # (T, 4)

    @classmethod
    def create(cls, root_pos, root_quat, spherical, revolute, dtype=torch.float64) -> PoseParams:
        as_leaf = lambda a: torch.tensor(np.asarray(a), dtype=dtype).requires_grad_(True)
        root_quat = torch.tensor(np.asarray(root_quat), dtype=dtype)
        return cls(as_leaf(root_pos), root_quat, torch.zeros(root_quat.shape[:-1] + (3,), dtype=dtype, requires_grad=True),
                   as_leaf(spherical), as_leaf(revolute))

    def rotation_leaves(self) -> list[torch.Tensor]:
        return [self.root_rotvec, self.spherical, self.revolute]

    def root_quat(self) -> torch.Tensor:
        return qt.quat_mul(self.root_base, qt.quat_from_axis_angle(self.root_rotvec))

    def joint_quats(self) -> torch.Tensor:
        """(T, 12, 4) in skeleton order; equals `joint_quats_from_params_torch` (tested) but
        gathers with index_select, whose backward is far cheaper than index_copy's."""
        axis = torch.as_tensor(HINGE_AXIS, dtype=self.revolute.dtype)
        quats = torch.cat((qt.quat_from_axis_angle(self.spherical), qt.quat_about_axis(self.revolute, axis)), dim=-2)
        return quats.index_select(-2, _JOINT_ORDER)

    @torch.no_grad()
    def clamp_to_limits(self) -> None:
        limits = torch.as_tensor(SPHERICAL_LIMITS, dtype=self.spherical.dtype)
        self.spherical.copy_(torch.maximum(torch.minimum(self.spherical, limits[..., 1]), limits[..., 0]))
        limits = torch.as_tensor(REVOLUTE_LIMITS, dtype=self.revolute.dtype)
        self.revolute.copy_(torch.maximum(torch.minimum(self.revolute, limits[:, 1]), limits[:, 0]))

    @torch.no_grad()
    def fold_root_rotation(self) -> None:
        """Move the root rotation vector into the base quaternion (keeps the exp map near 0)."""
        self.root_base.copy_(qt.quat_normalize(self.root_quat()))
        self.root_rotvec.zero_()

    def numpy(self) -> dict[str, np.ndarray]:
        with torch.no_grad():
            return {
                "root_pos": self.root_pos.double().numpy().copy(),
                "root_quat": qt.quat_normalize(self.root_quat()).double().numpy().copy(),
                "joint_quats": self.joint_quats().double().numpy().copy(),
                "spherical": self.spherical.double().numpy().copy(),
                "revolute": self.revolute.double().numpy().copy(),
            }


def points_on_links(link_pos, link_mats, links: torch.Tensor, offsets: np.ndarray) -> torch.Tensor:
    """World positions (..., N, 3) of points given in link frames (rotation matrices (..., 15, 3, 3))."""
    offsets = torch.as_tensor(offsets, dtype=link_pos.dtype).unsqueeze(-2)
    return link_pos.index_select(-2, links) + (link_mats.index_select(-3, links) * offsets).sum(-1)


# Fit points, then the 2 x 8 foot corners, as one gather.
_POINT_LINKS = torch.as_tensor(np.concatenate((FIT_LINKS, np.repeat(FOOT_LINKS, len(FOOT_CORNERS)))))
_POINT_OFFSETS = np.concatenate((FIT_OFFSETS, np.tile(FOOT_CORNERS, (len(FOOT_LINKS), 1))))


_ALL_LINKS = torch.arange(NUM_LINKS)


def link_centres(link_pos, link_mats) -> torch.Tensor:
    """(..., 15, 3) each link's centre of mass, from link positions (..., 15, 3) and rotation
    matrices (..., 15, 3, 3); LINK_MASS_FRACTIONS weighs them."""
    return points_on_links(link_pos, link_mats, _ALL_LINKS, LINK_COM_OFFSETS)


def mass_weighted(centres: torch.Tensor) -> torch.Tensor:
    """(..., 3) the mass-weighted mean of the link centres of mass (..., 15, 3): the body's centre of mass."""
    return (torch.as_tensor(LINK_MASS_FRACTIONS, dtype=centres.dtype).unsqueeze(-1) * centres).sum(-2)


def centre_of_mass(link_pos, link_mats) -> torch.Tensor:
    """Whole-body centre of mass (..., 3), from link positions (..., 15, 3) and rotation matrices (..., 15, 3, 3)."""
    return mass_weighted(link_centres(link_pos, link_mats))


def body_points(root_pos, root_quat, joint_quats, with_com: bool = False, with_links: bool = False):
    """Fit points (T, P, 3) and foot-box corners (T, 2, 8, 3) of a pose trajectory; with `with_com`
    its centre of mass (T, 3) as a third value, and with `with_links` too the links' centres of
    mass (T, 15, 3) as a fourth."""
    link_pos, link_mats = link_frames(root_pos, root_quat, joint_quats)
    points = points_on_links(link_pos, link_mats, _POINT_LINKS, _POINT_OFFSETS)
    fit, corners = points[..., :NUM_FIT, :], points[..., NUM_FIT:, :]
    corners = corners.reshape(corners.shape[:-2] + (len(FOOT_LINKS), len(FOOT_CORNERS), 3))
    if with_links:
        centres = link_centres(link_pos, link_mats)
        return fit, corners, mass_weighted(centres), centres
    if with_com:
        return fit, corners, centre_of_mass(link_pos, link_mats)
    return fit, corners


def motion_centre_of_mass(root_pos: np.ndarray, root_rot: np.ndarray, joint_rot: np.ndarray) -> np.ndarray:
    """Whole-body centre of mass (T, 3) of a motion's poses (numpy in and out)."""
    with torch.no_grad():
        link_pos, link_mats = link_frames(torch.as_tensor(root_pos), torch.as_tensor(root_rot), torch.as_tensor(joint_rot))
        return centre_of_mass(link_pos, link_mats).double().numpy()


def motion_foot_corners(root_pos: np.ndarray, root_rot: np.ndarray, joint_rot: np.ndarray) -> np.ndarray:
    """Foot-box corners (T, 2, 8, 3) of a motion's poses (numpy in and out), feet as FOOT_LINKS."""
    with torch.no_grad():
        _, corners = body_points(torch.as_tensor(root_pos), torch.as_tensor(root_rot), torch.as_tensor(joint_rot))
    return corners.double().numpy()
