"""How hard must the reconstruction hold a foot that is down? Issue 44: the reference's stance feet skate.

    python bench/scripts/slide_weight.py TRACK.npz=VIDEO [...] [--weights 100,1000] [--out bench/results/slide_weight.json]

Each TRACK.npz (a subject's pose track: `sfv pose VIDEO --out TRACK.npz --serial`, or a pipeline
run's `track.npz`) is reconstructed as `sfv pipeline` does it (static camera, learned contacts,
the reference check; `services/contacts/video_motion.py`) once per `w_slide`, and measured:

- stance_ankle_speed_m_s: the mean horizontal speed of each ankle between adjacent frames that
  the contact estimate calls it down at both (the slide term's own measure, on the joints);
- reprojection_px: the fit's mean confidence-weighted 2D error;
- hip_path_m: the length of the root's horizontal path;
- where the video has Pose2Sim markers and a calibration (`../shared`): PA-MPJPE, MPJPE after one
  similarity, acceleration error (mm, `bench/scripts/focal_effect.measure`, on the 30 Hz grid).
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

RESULT = REPO / "bench" / "results" / "slide_weight.json"


def stance_speed(motion) -> float:
    contacts = np.asarray(motion.extras["contacts"], bool)
    ankles = np.asarray(motion.extras["keypoints3d"])[:, [2, 5], :2]  # RAnkle, LAnkle (JOINT_KEYPOINTS order)
    speed = np.linalg.norm(np.diff(ankles, axis=0), axis=-1) * float(motion.fps)
    held = contacts[:-1] & contacts[1:]
    return float(speed[held].mean()) if held.any() else float("nan")


def truth_errors(video: Path, motion) -> dict:
    from bench.scripts.focal_effect import measure
    from services.bench.videos_truth import CALIBRATION, camera_key

    calibration_file = video.parent / CALIBRATION
    if not calibration_file.is_file():
        return {}
    calibration = tomllib.loads(calibration_file.read_text())[camera_key(video)]
    found = measure(video, motion, calibration)
    return {k: found[k] for k in ("pa_mpjpe_mm", "mpjpe_mm", "accel_error_mm") if k in found}


def measure_track(track_file: Path, video: Path, weights: list[float]) -> dict:
    from services.contacts.video_motion import video_motion
    from services.pose import PoseTrack
    from services.reconstruction import ReconstructionConfig

    track = PoseTrack.load(track_file)
    rows = {}
    for weight in weights:
        motion = video_motion(track, dataclasses.replace(ReconstructionConfig(), w_slide=weight), video.stem, "static",
                              str(video), use_ray=False).motion
        rows[f"{weight:g}"] = {
            "stance_ankle_speed_m_s": round(stance_speed(motion), 3),
            "reprojection_px": round(float(np.asarray(motion.extras["reprojection_error_px"]).mean()), 2),
            "hip_path_m": round(float(np.linalg.norm(np.diff(motion.root_pos[:, :2], axis=0), axis=1).sum()), 2),
            "frames": int(motion.num_frames), **truth_errors(video, motion)}
        print(video.parent.name, video.name, weight, rows[f"{weight:g}"], flush=True)
    return {"video": str(video), "by_w_slide": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pairs", nargs="+", help="TRACK.npz=VIDEO")
    parser.add_argument("--weights", default="100,1000")
    parser.add_argument("--out", type=Path, default=RESULT)
    args = parser.parse_args(argv)
    weights = [float(w) for w in args.weights.split(",")]
    results = []
    for pair in args.pairs:
        track, _, video = pair.partition("=")
        results.append(measure_track(Path(track), Path(video), weights))
        from learner.atomic_io import atomic_write_json
        atomic_write_json(args.out, {"weights": weights, "rows": results})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
