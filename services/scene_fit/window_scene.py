"""The scene as a later window sees it: in the frame of the window's first frame.

A scene file places its boxes in the clip's scene frame (the first frame's root position
and heading, `actors.arenas.scene.SceneFrame`), and the env builds the frame from the motion it is
given, which for a window is the window's own motion (`window_motion.py`). So each box is
carried through the world into the window's frame: its along and lateral change, its along
domain moves with its along, and the scene vector of the window is the clip's plus a fixed
`shift` (along entries only). Because the domain moves with the value, the normalised entries
the networks observe are the same numbers in every window, which lets the fit optimise the
clip's e directly.

Deviation: boxes stay aligned with the frame's heading, so where the clip's heading has
turned by a window's start, that window's boxes turn with it (by the heading change).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from actors.motion.reference_motion import ReferenceMotion


def window_scene(scene, clip: ReferenceMotion, motion: ReferenceMotion):
    """(scene in `motion`'s frame, shift of its scene vector from the clip's)."""
    from actors.arenas.scene import Scene, SceneFrame

    clip_frame, frame = SceneFrame.of_motion(clip), SceneFrame.of_motion(motion)
    boxes, shift = [], []
    for box in scene.boxes:
        along, lateral = frame.to_scene(clip_frame.to_world(box.along, box.lateral))
        delta = float(along - box.along)
        boxes.append(replace(box, along=float(along), lateral=float(lateral),
                             along_domain=(box.along_domain[0] + delta, box.along_domain[1] + delta)))
        shift += [delta, 0.0]
    return Scene(tuple(boxes)), np.asarray(shift, np.float64)
