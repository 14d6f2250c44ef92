"""How far a simulated character is from its reference: joint rotation and end-effector errors."""
from __future__ import annotations

import numpy as np

from actors.character.features import RewardFeatures


def tracking_errors(sim: RewardFeatures, ref: RewardFeatures) -> tuple[np.ndarray, np.ndarray]:
    """Per row: (mean joint rotation error over the character's joints in rad, mean
    end-effector distance in m; humanoid3d: 12 joints, 4 end effectors) between two equally
    long feature batches. The root's orientation is not a joint.

    Ball joints: the angle of q*^-1 q, 2 acos|<q, q*>|; hinges: |angle gap| wrapped to [0, pi].
    End effectors: Euclidean distance of the heading-frame positions."""
    dot = np.abs(np.vecdot(sim.quats[:, 1:], ref.quats[:, 1:]))  # (B, balls): the ball joints, root excluded
    ball = 2.0 * np.arccos(np.minimum(dot, 1.0))
    gap = np.abs(np.remainder(sim.hinges - ref.hinges + np.pi, 2.0 * np.pi) - np.pi)  # (B, hinges)
    rotation = (ball.sum(axis=1) + gap.sum(axis=1)) / (ball.shape[1] + gap.shape[1])
    end_effector = np.linalg.norm(sim.end_effectors - ref.end_effectors, axis=-1).mean(axis=1)
    return rotation, end_effector
