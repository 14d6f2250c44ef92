"""What a video would tell the movingcam tracker about a mocap clip: orientation hint and contacts.

The dynamic-camera paper (002 §4-5.1) trains from three cues a video gives besides joint
rotations: a body-orientation hint (eq. 7) and per-end-effector contact flags (eq. 8). A
motion reconstructed from video carries them as extras (`services/contacts/video_extras.py`);
a mocap clip (DeepMimic, BVH) does not, so for training a clip in movingcam mode, and for the
synthetic moving-camera check, they are computed from the clip itself:

- hint: the angle between the pelvis-to-neck vector and the world's up axis (eq. 7's theta on
  the clip, the root link's frame to the neck link's frame), confidence 1 on every frame. It
  is unsigned: the video hint's sign only says towards which side of the picture the body
  leans, which a 3D tilt has no counterpart of (see `actors/envs/modes/movingcam/reward.py`).
- contacts: a foot is down where the lowest corner of its box is within `CONTACT_HEIGHT_M` of
  the floor and it moves slower than `CONTACT_SPEED_MPS` horizontally (the paper labels its
  mocap "by the height and velocity of the foot", §4). Feet only: the hands' flags are, as
  in the paper, given by hand.
"""
from __future__ import annotations

import numpy as np

from actors.character.foot_contact import FOOT_LINKS, sole_heights
from actors.character.kinematics import forward_kinematics
from actors.motion.reference_motion import ReferenceMotion
from actors.character.skeleton import LINK_NAMES

CONTACT_HEIGHT_M = 0.03
CONTACT_SPEED_MPS = 1.5
NECK_LINK = LINK_NAMES.index("neck")
CONTACT_FEET = ("right", "left")  # the order of `contacts` columns, as video_extras writes them


def up_tilt(pelvis: np.ndarray, neck: np.ndarray) -> np.ndarray:
    """Angle (rad, in [0, pi]) between pelvis->neck (..., 3) and the world's +z."""
    up = neck - pelvis
    return np.arctan2(np.linalg.norm(up[..., :2], axis=-1), up[..., 2])


def clip_orientation_hint(motion: ReferenceMotion) -> np.ndarray:
    """(T,) up-tilt of the pelvis-to-neck vector at each frame of the clip."""
    pos, _ = forward_kinematics(motion.root_pos, motion.root_rot, motion.joint_rot)
    return up_tilt(pos[:, 0], pos[:, NECK_LINK])


def clip_contacts(motion: ReferenceMotion) -> np.ndarray:
    """(T, 2) bool foot contacts (right, left) at each frame of the clip."""
    pos, rot = forward_kinematics(motion.root_pos, motion.root_rot, motion.joint_rot)
    heights = sole_heights(pos, rot)
    feet = pos[:, list(FOOT_LINKS), :2]
    speed = np.linalg.norm(np.gradient(feet, motion.frame_times, axis=0), axis=-1)
    return (heights < CONTACT_HEIGHT_M) & (speed < CONTACT_SPEED_MPS)


def clip_cues(motion: ReferenceMotion) -> dict[str, np.ndarray]:
    """The extras a moving-camera reconstruction writes, computed from the clip itself."""
    hint = clip_orientation_hint(motion)
    return {"orientation_hint": hint, "orientation_hint_confidence": np.ones_like(hint),
            "contacts": clip_contacts(motion), "contact_feet": np.array(CONTACT_FEET)}
