"""Does the smoothness loss cost a moving subject its path? Issue 44: SFV's l_sm against the "body" form.

    python bench/scripts/smoothness_modes.py --runs RUNS [--shared ../shared] [--modes body:25,displacement:25]
                                            [--extra TRACK.npz ...] [--out bench/results/smoothness_modes.json]

Each pipeline run directory RUNS/<trial>_camNN/ with a `track.npz` is reconstructed as the pipeline
does it (`services/contacts/video_motion.py`), once per smoothness mode and weight
(`ReconstructionConfig.smoothness`, `w_smooth`), and scored against the markers of the person
followed as `focal_effect.py` scores it (PA-MPJPE, MPJPE, acceleration error, reprojection). Each
`--extra` pose track (a video without markers: a run, a walk) gets its reprojection error (mean,
first and last five frames), its root path's length and median speed, and its stance ankles'
horizontal speed (the feet its contacts hold down).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import tomllib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from bench.scripts.focal_effect import calibrated_runs, measure  # noqa: E402

RESULT = REPO / "bench" / "results" / "smoothness_modes.json"


def reconstruct(track, mode: str, weight: float, name: str, source: str):
    from services.contacts.video_motion import video_motion
    from services.reconstruction import ReconstructionConfig

    config = dataclasses.replace(ReconstructionConfig(), smoothness=mode, w_smooth=weight)
    return video_motion(track, config, name, "static", source, use_ray=False).motion


def path_figures(motion) -> dict:
    error = np.asarray(motion.extras["reprojection_error_px"])
    root = np.asarray(motion.root_pos)
    speed = np.linalg.norm(np.diff(root, axis=0), axis=1) * float(motion.fps)
    return {"reprojection_px": round(float(error.mean()), 1), "first5_px": round(float(error[:5].mean()), 1),
            "last5_px": round(float(error[-5:].mean()), 1), "path_m": round(float(np.linalg.norm(root[-1, :2] - root[0, :2])), 2),
            "median_speed_m_s": round(float(np.median(speed)), 2), "stance_ankle_m_s": stance_ankle_speed(motion)}


def stance_ankle_speed(motion) -> float | None:
    """Mean horizontal speed (m/s) of the ankles of the reconstruction (`keypoints3d`) over the
    frame pairs in which the contacts it was fitted to have that foot down at both frames."""
    if "contacts" not in motion.extras:
        return None
    names = [str(n) for n in motion.extras["keypoint_names"]]
    ankles = np.asarray(motion.extras["keypoints3d"])[:, [names.index("RAnkle"), names.index("LAnkle")], :2]
    down = np.asarray(motion.extras["contacts"], bool)
    held = down[1:] & down[:-1]
    speed = np.linalg.norm(np.diff(ankles, axis=0), axis=-1) * float(motion.fps)
    return round(float(speed[held].mean()), 2) if held.any() else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, required=True, help="pipeline run directories RUNS/<trial>_camNN/ with track.npz")
    parser.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="the shared data folder")
    parser.add_argument("--modes", default="body:25,displacement:25,acceleration:25", help="MODE:WEIGHT, comma-separated")
    parser.add_argument("--extra", type=Path, nargs="*", default=[], help="pose tracks without markers (runs, walks)")
    parser.add_argument("--out", type=Path, default=RESULT, help="the JSON written")
    args = parser.parse_args(argv)

    import torch

    from learner.atomic_io import atomic_write_json
    from services.bench.videos_truth import CALIBRATION, camera_key
    from services.pose import PoseTrack

    torch.set_num_threads(1)
    modes = [(m, float(w)) for m, w in (item.split(":") for item in args.modes.split(","))]
    cameras, extras = {}, {}
    for run, video in calibrated_runs(args.runs, args.shared, "smoothness_modes"):
        calibration = tomllib.loads((video.parent / CALIBRATION).read_text())[camera_key(video)]
        track = PoseTrack.load(run / "track.npz")
        for mode, weight in modes:
            result = measure(video, reconstruct(track, mode, weight, video.stem, str(video)), calibration)
            cameras.setdefault(run.name, {})[f"{mode}:{weight:g}"] = result
            print(run.name, mode, weight, {k: result[k] for k in ("pa_mpjpe_mm", "mpjpe_mm", "accel_error_mm", "reprojection_px")}, flush=True)
    for path in args.extra:
        track = PoseTrack.load(path)
        for mode, weight in modes:
            extras.setdefault(str(path), {})[f"{mode}:{weight:g}"] = figures = path_figures(reconstruct(track, mode, weight, path.stem, str(path)))
            print(path, mode, weight, figures, flush=True)
    means = {key: {k: round(float(np.mean([c[key][k] for c in cameras.values()])), 1)
                   for k in ("pa_mpjpe_mm", "mpjpe_mm", "accel_error_mm", "reprojection_px")}
             for key in (f"{m}:{w:g}" for m, w in modes)} if cameras else {}
    atomic_write_json(args.out, {"what": __doc__.split("\n\n")[0], "cameras": cameras, "mean": means, "extra": extras})
    return 0


if __name__ == "__main__":
    sys.exit(main())
