"""Are the feet on the floor where the contact estimator says they are down, and is the body over
them? The static-camera reconstruction of each Pose2Sim camera without and with the contact
terms (--compare contacts), or without and with the static-balance term (--compare balance).

    python bench/scripts/reconstruction_contacts.py [--cameras cam01,cam02,cam03,cam04] [--track-cache DIR]
                                          [--out bench/results/reconstruction_contacts.json] [--motions DIR]
    python bench/scripts/reconstruction_contacts.py --compare balance [--balance-weights 30,100]
                                          --out bench/results/reconstruction_balance.json

For each camera of ../shared/data/video/pose2sim_balancing (one person balancing, 100 frames at
60 fps), BlazePose runs on that camera alone (or its track comes from --track-cache) and the
motion is made by the path `sfv reconstruct` and `sfv pipeline` take (`contacts/video_motion.py`,
static camera, the learned contacts), once with w_contact = w_slide = 0 ("before": the
reconstruction as it was) and once with the defaults ("after"). Per motion, on its 60 fps
frames, with the feet the estimator calls down:

- contact_foot_height_cm: |height| of a contact foot's lowest point above the floor, mean / max
  over contact foot-frames; frame0_sole_height_cm: both feet's at the clip's first frame;
- penetration_cm: the deepest foot point below the floor, max over frames;
- contact_foot_skating_m_s: the contact feet's horizontal speed over frame pairs down at both
  ends (`services/pipeline/metrics.foot_skating`, the report's measure);
- reprojection_error_px: the confidence-weighted mean 2D error of the fit;
- against the 12 joints triangulated from all four cameras: MPJPE, PA-MPJPE, acceleration error
  (hip-centred, `reconstruction/metrics.py`, as `reconstruction_benchmark.py`);
- balance (--compare balance): the horizontal distance of the whole-body centre of mass (the
  humanoid's link masses) and of the hip midpoint from the support of the contact feet
  (`losses.support_distance`: a foot's heel-toe segment, or with both down the convex hull of
  their heels and toes), mean / max over the frames with a foot down; and in the one-leg stance
  (video frames STANCE_FRAMES, stance foot: the markers' lower ankle there) the hip midpoint's
  distance from the stance ankle and the centre of mass's from the stance foot's segment,
  mean / min / max. The markers get the same figures, the support from their own heel and
  big-toe markers and their own contacts (a foot's lowest marker within MARKER_CONTACT_M of its
  5th percentile over the clip: the markers sit at different heights on the two feet), the
  centre of mass approximated from the markers with the humanoid's mass distribution
  (`keypoint_centre_of_mass`; on the reconstruction itself that approximation is off from the
  true one by `com_approximation_error_cm`).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

from actors.motion.formats.io import save_motion  # noqa: E402
from actors.motion.formats.trc import read_trc_markers  # noqa: E402
from learner.atomic_io import atomic_write_json  # noqa: E402
from bench.scripts.reconstruction_benchmark import CLIP_DIR, HIPS, TRC_FILES, pose_track  # noqa: E402
from services.contacts.video_motion import video_motion  # noqa: E402
from services.pipeline import metrics  # noqa: E402
from services.reconstruction import JOINT_KEYPOINTS, ReconstructionConfig  # noqa: E402
from services.reconstruction.body import body_points, motion_centre_of_mass, motion_foot_corners  # noqa: E402
from services.reconstruction.keypoints import FIT_NAMES  # noqa: E402
from services.reconstruction.losses import support_distance  # noqa: E402
from services.reconstruction.metrics import evaluate  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
COMPARISONS = {
    "contacts": {"before": {"w_contact": 0.0, "w_slide": 0.0, "w_balance": 0.0}, "after": {"w_balance": 0.0}},
    "balance": {"before": {"w_balance": 0.0}, "after": {}},
}
SETTINGS = COMPARISONS["contacts"]
STANCE_FRAMES = (20, 41)  # video frames [start, stop) of the one-leg stance on the left foot
MARKER_CONTACT_M = 0.05
# The markers the balance figures read: joints, feet, the head and OpenPose's neck (shoulder midpoint).
MARKERS = ("RHip", "RKnee", "RAnkle", "LHip", "LKnee", "LAnkle", "RShoulder", "RElbow", "RWrist", "LShoulder",
           "LElbow", "LWrist", "Head", "Neck", "RHeel", "RBigToe", "LHeel", "LBigToe", "RSmallToe", "LSmallToe")


def keypoint_centre_of_mass(p: dict) -> np.ndarray:
    """(T, 3) the centre of mass of a body given by keypoints (name -> (T, 3)), each link's mass
    (the humanoid's, `skeleton.LINKS`) placed where the humanoid has its link's centre along the
    keypoints' bones: pelvis 0.07 and chest 0.356 of 0.48 m up the hip-midpoint-to-shoulder-midpoint
    line, the head at the head point, thigh, shank, upper arm and forearm at 0.5, 0.49, 0.51, 0.46
    of their bones, a foot at the mean of its ankle, heel and toe, a hand at the wrist."""
    from actors.character.skeleton import LINK_NAMES, LINKS

    hips = 0.5 * (p["RHip"] + p["LHip"])
    trunk = 0.5 * (p["RShoulder"] + p["LShoulder"]) - hips
    along = lambda a, b, f: p[a] + f * (p[b] - p[a])  # noqa: E731
    centres = {"root": hips + 0.07 / 0.48 * trunk, "chest": hips + 0.356 / 0.48 * trunk, "neck": p["Head"]}
    for side, s in (("right", "R"), ("left", "L")):
        centres[f"{side}_hip"] = along(f"{s}Hip", f"{s}Knee", 0.5)
        centres[f"{side}_knee"] = along(f"{s}Knee", f"{s}Ankle", 0.49)
        centres[f"{side}_ankle"] = (p[f"{s}Ankle"] + p[f"{s}Heel"] + p[f"{s}Toe"]) / 3.0
        centres[f"{side}_shoulder"] = along(f"{s}Shoulder", f"{s}Elbow", 0.51)
        centres[f"{side}_elbow"] = along(f"{s}Elbow", f"{s}Wrist", 0.46)
        centres[f"{side}_wrist"] = p[f"{s}Wrist"]
    masses = np.array([link.mass for link in LINKS])
    return sum(m * centres[name] for m, name in zip(masses, LINK_NAMES)) / masses.sum()


def _horizontal_support(point: np.ndarray, heels: np.ndarray, toes: np.ndarray, contacts: np.ndarray) -> np.ndarray:
    """(T,) `losses.support_distance` of points (T, 3) from feet (T, 2, 3) in numpy, metres."""
    import torch

    t = lambda a: torch.as_tensor(np.asarray(a, dtype=np.float64))  # noqa: E731
    return support_distance(t(point[:, :2]), t(heels[..., :2]), t(toes[..., :2]), t(contacts)).numpy()


def _stats(values: np.ndarray, keys=("mean", "max")) -> dict:
    do = {"mean": np.mean, "min": np.min, "max": np.max}
    return {k: round(100 * float(do[k](values)), 1) for k in keys}


def balance_figures(points: dict, com: np.ndarray, contacts: np.ndarray, stance: slice, stance_foot: int) -> dict:
    """Balance figures of one body (keypoints name -> (T, 3), centre of mass (T, 3), z up) with its
    contacts (T, 2) (right, left), in centimetres."""
    hips = 0.5 * (points["RHip"] + points["LHip"])
    heels, toes = np.stack((points["RHeel"], points["LHeel"]), 1), np.stack((points["RToe"], points["LToe"]), 1)
    down = contacts.any(axis=1)
    one = np.zeros_like(contacts, dtype=float)
    one[:, stance_foot] = 1.0
    ankle = points[("RAnkle", "LAnkle")[stance_foot]]
    horizontal = lambda a, b: np.linalg.norm((a - b)[:, :2], axis=-1)  # noqa: E731
    return {
        "com_to_support_cm": _stats(_horizontal_support(com, heels, toes, contacts)[down]),
        "hip_to_support_cm": _stats(_horizontal_support(hips, heels, toes, contacts)[down]),
        "stance_hip_to_ankle_cm": _stats(horizontal(hips, ankle)[stance], ("mean", "min", "max")),
        "stance_com_to_foot_cm": _stats(_horizontal_support(com, heels, toes, one)[stance], ("mean", "min", "max")),
        "contact_frames": int(down.sum()),
    }


def motion_keypoints(motion) -> dict:
    """The reconstruction's fit points (name -> (T, 3)), with OpenPose's 'Neck' as the shoulder midpoint."""
    import torch

    with torch.no_grad():
        fit, _ = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot),
                             torch.as_tensor(motion.joint_rot))
    points = dict(zip(FIT_NAMES, np.moveaxis(fit.double().numpy(), 1, 0)))
    return points


def marker_points(markers: np.ndarray) -> dict:
    """The markers (T, len(MARKERS), 3) by the fit points' names (toe: the big toe)."""
    points = dict(zip(MARKERS, np.moveaxis(markers, 1, 0)))
    points["RToe"], points["LToe"] = points["RBigToe"], points["LBigToe"]
    return points


def marker_contacts(points: dict) -> np.ndarray:
    """(T, 2) feet (right, left) whose lowest marker is within MARKER_CONTACT_M of its 5th percentile over the clip."""
    lowest = np.stack([np.min([points[f"{s}{m}"][:, 2] for m in ("Ankle", "Heel", "BigToe", "SmallToe")], axis=0)
                       for s in "RL"], axis=1)
    return lowest < np.percentile(lowest, 5.0, axis=0) + MARKER_CONTACT_M


def stance_window(start: int, frames: int) -> slice:
    """The motion's frames (slice) of STANCE_FRAMES, for a motion starting at video frame `start`."""
    return slice(max(STANCE_FRAMES[0] - start, 0), max(min(STANCE_FRAMES[1] - start, frames), 0))


def marker_balance(markers: np.ndarray, start: int, frames: int) -> dict:
    points = {k: v[start:start + frames] for k, v in marker_points(markers).items()}
    stance = stance_window(start, frames)
    foot = int(np.argmin([points["RAnkle"][stance, 2].mean(), points["LAnkle"][stance, 2].mean()]))
    result = balance_figures(points, keypoint_centre_of_mass(points), marker_contacts(points), stance, foot)
    return {**result, "stance_foot": ("right", "left")[foot], "com": "approximated from the markers"}


def motion_balance(motion, stance_foot: str) -> dict:
    points = motion_keypoints(motion)
    com = motion_centre_of_mass(motion.root_pos, motion.root_rot, motion.joint_rot)
    stance = stance_window(int(motion.extras["video_start_frame"]), motion.num_frames)
    result = balance_figures(points, com, np.asarray(motion.extras["contacts"], bool), stance,
                             ("right", "left").index(stance_foot))
    approximate = keypoint_centre_of_mass(points)
    result["com_approximation_error_cm"] = _stats(np.linalg.norm((approximate - com)[:, :2], axis=-1))
    return result


def figures(motion, truth: np.ndarray, markers: np.ndarray | None = None) -> dict:
    corners = motion_foot_corners(motion.root_pos, motion.root_rot, motion.joint_rot)
    heights = corners[..., 2].min(axis=-1)  # (T, 2)
    contacts = np.asarray(motion.extras["contacts"], bool)
    down = np.abs(heights[contacts])
    skating = metrics.foot_skating(corners.mean(axis=-2), contacts, motion.fps)
    start = int(motion.extras["video_start_frame"])
    accuracy = evaluate(motion.extras["keypoints3d"], truth[start:start + motion.num_frames], HIPS)
    return {
        "contact_foot_height_cm": {"mean": round(100 * float(down.mean()), 2), "max": round(100 * float(down.max()), 2)},
        "frame0_sole_height_cm": dict(zip(("right", "left"), np.round(100 * heights[0], 2).tolist())),
        "frame0_contacts": dict(zip(("right", "left"), contacts[0].tolist())),
        "penetration_cm": round(100 * float(metrics.ground_penetration(corners[..., 2]).max()), 3),
        "contact_foot_skating_m_s": None if skating is None else round(skating, 3),
        "reprojection_error_px": round(float(np.mean(motion.extras["reprojection_error_px"])), 2),
        **{k: round(v, 1) for k, v in accuracy.items()},
        **({} if markers is None else
           {"balance": motion_balance(motion, marker_balance(markers, start, motion.num_frames)["stance_foot"])}),
    }


def measure_camera(video: Path, truth: np.ndarray, models: Path, cache: Path | None, config: ReconstructionConfig,
                   motions: Path | None, settings: dict = SETTINGS, markers: np.ndarray | None = None) -> dict:
    track = pose_track(video, models, cache)
    result = {}
    for name, change in settings.items():
        started = time.perf_counter()
        motion = video_motion(track, dataclasses.replace(config, **change), video.stem, "static", str(video),
                              use_ray=False).motion
        result[name] = {**figures(motion, truth, markers), "seconds": round(time.perf_counter() - started, 1)}
        if motions is not None:
            save_motion(motion, motions / f"{video.stem}_{name.replace('=', '')}.npz")
        print(f"{video.stem} {name}: {result[name]}", file=sys.stderr, flush=True)
    result["contact_frames"] = {"right": int(motion.extras["contacts"][:, 0].sum()),
                                "left": int(motion.extras["contacts"][:, 1].sum()), "of": motion.num_frames}
    if markers is not None:
        result["markers"] = {"balance": marker_balance(markers, int(motion.extras["video_start_frame"]), motion.num_frames)}
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="the shared data folder")
    parser.add_argument("--pose-models", type=Path, default=None, help="BlazePose models (default: shared/models/blazepose)")
    parser.add_argument("--cameras", default="cam01,cam02,cam03,cam04", help="comma-separated camera videos")
    parser.add_argument("--iterations", type=int, default=ReconstructionConfig().iterations)
    parser.add_argument("--track-cache", type=Path, default=None, help="keep pose tracks here and reuse them")
    parser.add_argument("--out", type=Path, default=None, help="write the results as JSON here (bench/results/...)")
    parser.add_argument("--motions", type=Path, default=None,
                        help="also write each motion here, CAMERA_before.npz / CAMERA_after.npz (for pd_tracking.py)")
    parser.add_argument("--compare", choices=sorted(COMPARISONS), default="contacts",
                        help="contacts: without / with the contact terms; balance: without / with the static-balance term")
    parser.add_argument("--balance-weights", default="",
                        help="also reconstruct with these w_balance values (comma-separated), as settings w_balance=X")
    args = parser.parse_args(argv)
    clip = args.shared / CLIP_DIR
    if not (clip / TRC_FILES["triangulated"]).is_file():
        print(f"reconstruction_contacts: {clip / TRC_FILES['triangulated']} not found (needs ../shared)", file=sys.stderr)
        return 2
    models = args.pose_models or args.shared / "models" / "blazepose"
    truth = read_trc_markers(clip / TRC_FILES["triangulated"], JOINT_KEYPOINTS)
    markers = read_trc_markers(clip / TRC_FILES["triangulated"], MARKERS) if args.compare == "balance" else None
    config = dataclasses.replace(ReconstructionConfig(), iterations=args.iterations)
    settings = dict(COMPARISONS[args.compare])
    for weight in [float(w) for w in args.balance_weights.split(",") if w.strip()]:
        settings[f"w_balance={weight:g}"] = {"w_balance": weight}
    if args.motions is not None:
        args.motions.mkdir(parents=True, exist_ok=True)
    results = {camera: measure_camera(clip / f"{camera}.mp4", truth, models, args.track_cache, config, args.motions,
                                      settings, markers)
               for camera in args.cameras.split(",")}
    document = {"clip": str(CLIP_DIR), "truth": TRC_FILES["triangulated"], "settings": settings,
                "defaults": {"w_balance": config.w_balance, "balance_margin_m": config.balance_margin_m},
                "iterations": args.iterations, "cameras": results}
    if args.out:
        atomic_write_json(args.out, document)
    return 0


if __name__ == "__main__":
    sys.exit(main())
