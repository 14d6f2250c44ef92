"""Are the feet on the floor where the contact estimator says they are down? The static-camera
reconstruction of each Pose2Sim camera without and with the contact terms.

    python services/bench/scripts/reconstruction_contacts.py [--cameras cam01,cam02,cam03,cam04] [--track-cache DIR]
                                          [--out bench/results/reconstruction_contacts.json] [--motions DIR]

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
  (hip-centred, `reconstruction/metrics.py`, as `reconstruction_benchmark.py`).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # run from a checkout without installing

from actors.motion.formats.io import save_motion  # noqa: E402
from learner.atomic_io import atomic_write_json  # noqa: E402
from services.bench.scripts.reconstruction_benchmark import CLIP_DIR, HIPS, TRC_FILES, pose_track, read_trc  # noqa: E402
from services.contacts.video_motion import video_motion  # noqa: E402
from services.pipeline import metrics  # noqa: E402
from services.reconstruction import JOINT_KEYPOINTS, ReconstructionConfig  # noqa: E402
from services.reconstruction.body import motion_foot_corners  # noqa: E402
from services.reconstruction.metrics import evaluate  # noqa: E402

REPO = Path(__file__).resolve().parents[3]
SETTINGS = {"before": {"w_contact": 0.0, "w_slide": 0.0}, "after": {}}


def figures(motion, truth: np.ndarray) -> dict:
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
    }


def measure_camera(video: Path, truth: np.ndarray, models: Path, cache: Path | None, config: ReconstructionConfig,
                   motions: Path | None) -> dict:
    track = pose_track(video, models, cache)
    result = {}
    for name, change in SETTINGS.items():
        started = time.perf_counter()
        motion = video_motion(track, dataclasses.replace(config, **change), video.stem, "static", str(video),
                              use_ray=False).motion
        result[name] = {**figures(motion, truth), "seconds": round(time.perf_counter() - started, 1)}
        if motions is not None:
            save_motion(motion, motions / f"{video.stem}_{name}.npz")
        print(f"{video.stem} {name}: {result[name]}", file=sys.stderr, flush=True)
    result["contact_frames"] = {"right": int(motion.extras["contacts"][:, 0].sum()),
                                "left": int(motion.extras["contacts"][:, 1].sum()), "of": motion.num_frames}
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
    args = parser.parse_args(argv)
    clip = args.shared / CLIP_DIR
    if not (clip / TRC_FILES["triangulated"]).is_file():
        print(f"reconstruction_contacts: {clip / TRC_FILES['triangulated']} not found (needs ../shared)", file=sys.stderr)
        return 2
    models = args.pose_models or args.shared / "models" / "blazepose"
    truth = read_trc(clip / TRC_FILES["triangulated"], JOINT_KEYPOINTS)
    config = dataclasses.replace(ReconstructionConfig(), iterations=args.iterations)
    if args.motions is not None:
        args.motions.mkdir(parents=True, exist_ok=True)
    results = {camera: measure_camera(clip / f"{camera}.mp4", truth, models, args.track_cache, config, args.motions)
               for camera in args.cameras.split(",")}
    document = {"clip": str(CLIP_DIR), "truth": TRC_FILES["triangulated"], "settings": SETTINGS,
                "iterations": args.iterations, "cameras": results}
    if args.out:
        atomic_write_json(args.out, document)
    return 0


if __name__ == "__main__":
    sys.exit(main())
