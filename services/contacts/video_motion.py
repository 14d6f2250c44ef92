"""Video pose track -> the motion file every command writes: one path for `sfv reconstruct`,
the static `sfv pipeline` and `sfv pipeline --camera moving`.

The track is cut to the frames where the subject is seen (`video_start_frame` says where the
motion starts in the video), the camera decided (static / moving / auto from the background's
motion), and the reconstruction (a Ray task or in this process) is given the learned
foot-contact estimate, which it records and, for a static camera, fits the feet to (feet on the
ground and not sliding where they are down, `services/reconstruction/contact_fit.py`). A moving
camera keeps the contacts as cues only: the static-camera world the fit uses moves with the
pan, so a foot held still there would fight the keypoints; its motion is written root-free,
with the root path its contacts give as `root_path` (`root_path.py`).
A static camera's root path is then checked for launches no body makes and repaired where it
has them (`services/reconstruction/plausibility.py`); `VideoMotion.check` is the one line that
says what was found, also kept in the motion as `reference_check`.
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np


@dataclass
class VideoMotion:
    motion: object  # actors.motion.reference_motion.ReferenceMotion with the video's extras
    track: object  # the services.pose.PoseTrack it was made from (cut to the subject's frames)
    path: object  # services.pose.camera_path.CameraPath, or None where the track did not measure it
    moving: bool
    check: str = ""  # the reference check's one line (static camera)


def video_motion(track, config, name: str, camera: str, source: str, use_ray: bool = True, say=None) -> VideoMotion:
    """The reconstruction of `track` (from `source`, a file name for error lines) with its extras;
    `say` gets the lines naming the subject's frames the motion covers where that is not all of
    them (a long gap cut or interpolated, a start left out); motion.npz keeps them (`subject_lines`)."""
    from services.contacts.estimator import track_contacts
    from services.contacts.video_extras import video_extras
    from services.pose.camera_path import camera_path, decide_camera
    from services.pose.subject import crop_to_seen, track_window
    from services.pose.view_edges import at_the_sides
    from services.reconstruction import reconstruct_on_ray, reconstruct_track
    from services.reconstruction.plausibility import check_reference, unsettled_end, unsettled_start
    from services.reconstruction.root_free import make_root_free
    from services.reconstruction.root_path import root_path_extras

    said: list[str] = []  # the subject-frames lines, kept in motion.npz (and report.json) as well as said

    def tell(line: str) -> None:
        said.append(line)
        if say is not None:
            say(line)

    reconstruct = reconstruct_on_ray if use_ray else reconstruct_track

    def path_of(track):
        return None if track.camera_homography is None else camera_path(track.camera_homography, track.image_size)

    def reconstructed(track, path):
        """The track's motion with the video's extras."""
        # a static camera's picture shows a planted foot standing still (planted.py); a moving one's does not
        contacts = track_contacts if moving else functools.partial(track_contacts, static_camera=True)
        motion = reconstruct(track, config, name, contacts)
        motion.extras.update(video_extras(track, path, moving))
        return motion

    track = crop_to_seen(track, source, tell)
    lead, trail = at_the_sides(track)
    if (lead or trail) and len(track) - lead - trail >= MIN_FRAMES_AFTER_CUT:
        # a subject walking in or out at the picture's side: half a body, read whole
        track = track_window(track, lead, len(track) - trail)
        tell(f"subject frames: {_left_at_sides(track, lead, trail)}; --frames A:B chooses others")
    path = path_of(track)
    moving = decide_camera(camera, path, track.image_size[0], source)
    if moving:
        config = dataclasses.replace(config, w_contact=0.0, w_slide=0.0)
    motion = reconstructed(track, path)
    if moving:
        free = make_root_free(motion)
        free.extras.update(root_path_extras(free))  # the path the contacts give (root_path.py)
        return VideoMotion(free, track, path, moving)
    # The ends are judged before the check repairs the root: the repair re-places a thrown frame's
    # root and keeps its pose, which is wrong with it (half a body read whole).
    (cut, jolt), (tail, tail_jolt) = unsettled_start(motion), unsettled_end(motion)
    motion, check = check_reference(motion, motion.extras.get("contacts"))
    if (cut or tail) and len(track) - cut - tail >= MIN_FRAMES_AFTER_CUT:
        # a subject coming into view or leaving it: keep the frames where the motion is settled
        track = track_window(track, cut, len(track) - tail)
        path = path_of(track)
        tell(f"subject frames: {_left_out(track, cut, tail, max(jolt if cut else 0.0, tail_jolt if tail else 0.0))}; "
             "--frames A:B chooses others")
        motion = reconstructed(track, path)
        motion, check = check_reference(motion, motion.extras.get("contacts"))
    motion.extras["reference_check"] = np.array(check.line)
    if said:
        motion.extras["subject_lines"] = np.array(said)
    return VideoMotion(motion, track, path, moving, check.line)


MIN_FRAMES_AFTER_CUT = 30  # a second at 30 fps: a shorter motion is no clip to learn from


def _left_out(track, cut: int, tail: int, jolt: float) -> str:
    """What the cut leaves out, said in words: the first and/or the last frames, and why."""
    fps = float(track.fps)
    parts = [f"the first {cut} ({cut / fps:.2f} s)"] if cut else []
    parts += [f"the last {tail} ({tail / fps:.2f} s)"] if tail else []
    return (f"frames {track.start_frame}-{track.start_frame + len(track) - 1} ({' and '.join(parts)} are left out: the "
            f"root's velocity changes by up to {jolt:.1f} m/s from one frame to the next there, as a body half in view is read)")


def _left_at_sides(track, lead: int, trail: int) -> str:
    """What the side cut leaves out, in words (`services/pose/view_edges.py`)."""
    from services.pose.view_edges import EDGE_FRACTION

    fps = float(track.fps)
    parts = [f"the first {lead} ({lead / fps:.2f} s)"] if lead else []
    parts += [f"the last {trail} ({trail / fps:.2f} s)"] if trail else []
    return (f"frames {track.start_frame}-{track.start_frame + len(track) - 1} ({' and '.join(parts)} are left out: the "
            f"hips within {100 * EDGE_FRACTION:.0f} % of the picture's side, half the body out of view)")
