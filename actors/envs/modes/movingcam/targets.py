"""The video's cues per reference-table row: orientation hint, its weight, contact flags.

movingcam (002 §5.1) scores the simulation against three things a video gives: joint
rotations (the reference track), the body-orientation hint (eq. 7) and the end effectors'
contact flags (eq. 8). This tabulates the last two on the control-step grid of a
`ReferenceTrack`, once per env process, so a step reads them with one gather.

Where they come from: the motion's extras (`orientation_hint`, `orientation_hint_confidence`,
`contacts` with its column names `contact_feet`), as a moving-camera reconstruction writes
them; a mocap clip without them gets them from the clip itself (`actors/envs/modes/movingcam/clip_cues.py`). A
root-free motion (reconstructed from a moving camera) that lacks them is an error naming the
file: nothing else could stand in for what the video saw.

Frames map to rows by time (looped clips wrap): the hint is interpolated linearly, contacts
are the nearest frame's. A hint frame whose confidence is below `min_confidence` has weight 0
(the person was not seen well enough for the angle to mean anything; the paper does not say
what it does there): its orientation error counts as 0 in the reward and the termination.
"""
from __future__ import annotations

import numpy as np

from actors.envs.modes.movingcam.clip_cues import clip_cues
from actors.motion.reference_motion import MotionFormatError
from actors.motion.formats.io import root_is_free
from actors.character.skeleton import LINK_NAMES

# Contact column names -> the link whose geom touches (ankles carry the feet, wrists the hands).
CONTACT_LINKS = {"right": "right_ankle", "left": "left_ankle", "right_foot": "right_ankle", "left_foot": "left_ankle",
                 "right_hand": "right_wrist", "left_hand": "left_wrist"}
HAND_NAMES = ("right_hand", "left_hand")


class MovingcamTargets:
    """hint (rows,), hint_weight (rows,) in {0, 1}, contacts (rows, E) float 0/1, and
    `contact_links` (E,) skeleton link indices of the E flagged end effectors."""

    def __init__(self, track, min_confidence: float):
        motion = track.motion
        extras = self._extras(motion)
        source = motion.source or motion.name
        frames = motion.num_frames
        hint = np.asarray(extras["orientation_hint"], dtype=np.float64).reshape(-1)
        confidence = np.asarray(extras.get("orientation_hint_confidence", np.ones(frames)), dtype=np.float64).reshape(-1)
        contacts = np.asarray(extras["contacts"])
        if contacts.ndim == 1:
            contacts = contacts[:, None]
        names = tuple(str(n) for n in np.asarray(extras.get("contact_feet", ("right", "left")[:contacts.shape[1]])).reshape(-1))
        for what, array in (("orientation_hint", hint), ("orientation_hint_confidence", confidence), ("contacts", contacts)):
            if len(array) != frames:
                raise MotionFormatError(f"{source}: '{what}' has {len(array)} frames, the motion {frames}")
            if not np.isfinite(array.astype(np.float64)).all():
                raise MotionFormatError(f"{source}: '{what}' holds NaN or infinite values")
        if len(names) != contacts.shape[1] or any(n not in CONTACT_LINKS for n in names):
            raise MotionFormatError(f"{source}: 'contact_feet' {names} must name the {contacts.shape[1]} contact columns "
                                    f"(of {', '.join(CONTACT_LINKS)})")
        self.contact_names = names
        self.contact_links = np.array([LINK_NAMES.index(CONTACT_LINKS[n]) for n in names], dtype=np.int64)
        self.has_hands = any(n in HAND_NAMES for n in names)
        times = np.mod(track.times, motion.duration) if motion.loop else np.minimum(track.times, motion.duration)
        self.hint = np.interp(times, motion.frame_times, hint)
        nearest = np.clip(np.rint(np.interp(times, motion.frame_times, np.arange(frames))).astype(np.int64), 0, frames - 1)
        self.hint_weight = (confidence[nearest] >= min_confidence).astype(np.float64)
        self.contacts = (contacts[nearest] > 0.5).astype(np.float64)

    @staticmethod
    def _extras(motion) -> dict:
        """The motion's cues; a mocap clip's own where it has none."""
        extras = motion.extras
        needed = ("orientation_hint", "contacts")
        missing = [k for k in needed if k not in extras]
        if not missing:
            return extras
        if root_is_free(motion):
            raise MotionFormatError(f"{motion.source or motion.name}: movingcam mode needs the video's {' and '.join(missing)} "
                                    "(a moving-camera reconstruction writes them); this root-free motion has none")
        return {**clip_cues(motion), **_present(extras, missing)}


def _present(extras: dict, missing: list[str]) -> dict:
    """The cue arrays a motion does have (kept over the clip's own), with their companions."""
    keep = {"orientation_hint": ("orientation_hint", "orientation_hint_confidence"), "contacts": ("contacts", "contact_feet")}
    return {k: extras[k] for cue, keys in keep.items() if cue not in missing for k in keys if k in extras}
