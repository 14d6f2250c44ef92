"""The flat-stance term (`losses.stance_tilt`, `ReconstructionConfig.w_flat`): a foot the contact
estimator says is down stands on its sole, not on the tips of its toes."""
import dataclasses

import numpy as np
import pytest
import torch

from services.reconstruction import ReconstructionConfig, reconstruct_track
from services.reconstruction.body import body_points
from services.reconstruction.keypoints import fit_index
from services.reconstruction.losses import stance_tilt
from services.reconstruction.synthetic import make_standing_clip
from services.pose.track import KEYPOINT_NAMES

FAST = ReconstructionConfig(iterations=100, ik_iterations=60, focal_length_px=600.0)
TOES = [fit_index("RToe"), fit_index("LToe")]
HEELS = [fit_index("RHeel"), fit_index("LHeel")]


def test_stance_tilt_counts_feet_in_contact_only():
    heels = torch.zeros((2, 2, 3), dtype=torch.float64)
    toes = torch.zeros((2, 2, 3), dtype=torch.float64)
    toes[:, 0, 2] = -0.05  # the right toe 5 cm below its heel in both frames
    toes[1, 1, 2] = 0.02  # the left toe 2 cm above it in the second
    contacts = torch.tensor([[1.0, 1.0], [0.0, 1.0]], dtype=torch.float64)
    assert torch.allclose(stance_tilt(heels, toes, contacts, 0.01), torch.tensor([25.0, 4.0], dtype=torch.float64))


def both_feet_down(track, label_flipped):
    frames = len(label_flipped)
    return np.tile([0.9, 0.9], (frames, 1)), np.tile([True, True], (frames, 1))


def right_stance_tilt_cm(motion) -> float:
    fit, _ = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot), torch.as_tensor(motion.joint_rot))
    return float((fit[:, TOES[0], 2] - fit[:, HEELS[0], 2]).abs().mean()) * 100.0


@pytest.mark.parametrize("default", [ReconstructionConfig().w_flat])
def test_a_toe_the_3d_prediction_reads_low_does_not_tilt_a_standing_foot(default):
    assert default > 0  # on by default
    clip = make_standing_clip(frames=12, right_foot_misread_m=0.0)
    toe = KEYPOINT_NAMES.index("right_foot_index")
    clip.track.world3d[:, toe, 1] += 0.08  # camera axes, y down: the prediction points the right toe 8 cm down
    off = reconstruct_track(clip.track, dataclasses.replace(FAST, w_flat=0.0), "standing", contact_estimate=both_feet_down)
    on = reconstruct_track(clip.track, dataclasses.replace(FAST, w_flat=100.0), "standing", contact_estimate=both_feet_down)
    names = list(on.extras["final_loss_names"])
    assert off.extras["final_losses"][names.index("flat")] == 0.0  # off: not computed
    # the truth stands flat; the prediction's toe pulls the fit's down, the term puts the sole back
    assert right_stance_tilt_cm(on) < 0.5 * right_stance_tilt_cm(off)
