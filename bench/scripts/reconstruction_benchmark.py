"""Accuracy of video -> motion reconstruction against multi-view ground truth.

    python bench/scripts/reconstruction_benchmark.py --out reconstruction.json [--iterations N] [--track-cache DIR]

For each of the 4 cameras of ../shared/data/video/pose2sim_balancing (one person, 100
frames at 60 fps), BlazePose runs on that camera's video alone and the motion is
reconstructed from it; the 12 joints are compared with the markers of the same names
triangulated from all 4 cameras (`*.trc`, world = trc[:, [2, 0, 1]]).

Rows: "raw" is BlazePose's per-frame 3D prediction (its world landmarks), "raw, labels
fixed" the same after undoing left/right misreadings, "reconstruction" the humanoid's
joints after SFV's motion reconstruction. All trajectories are hip-centred per frame; MPJPE
uses one similarity alignment (rotation, scale, translation) for the whole clip, PA-MPJPE one
per frame, acceleration error is the mean |second difference| gap (mm/frame^2) after the
clip alignment. The .trc is measured twice: as triangulated, and Butterworth-filtered (the
second file Pose2Sim ships): triangulation jitter alone puts a floor under acceleration
errors against the unfiltered markers, reported as "gt floor".
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

from actors.motion.formats.trc import read_trc_markers  # noqa: E402
from learner.atomic_io import atomic_write_json  # noqa: E402
from services.pose import PoseTrack, estimate_video  # noqa: E402
from services.reconstruction import JOINT_KEYPOINTS, ReconstructionConfig, reconstruct_track  # noqa: E402
from services.reconstruction.keypoints import observe  # noqa: E402
from services.reconstruction.label_flips import undo_label_flips  # noqa: E402
from services.reconstruction.metrics import acceleration_error, centre_on, evaluate  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
CLIP_DIR = Path("data") / "video" / "pose2sim_balancing"
TRC_FILES = {"triangulated": "S00_P00_T01_BalancingTrial_0-100.trc",
             "filtered": "S00_P00_T01_BalancingTrial_0-100_filt_butterworth.trc"}
HIPS = [JOINT_KEYPOINTS.index("RHip"), JOINT_KEYPOINTS.index("LHip")]


def pose_track(video: Path, models: Path, cache: Path | None) -> PoseTrack:
    cached = cache / f"{video.stem}_track.npz" if cache else None
    if cached and cached.is_file():
        return PoseTrack.load(cached)
    track = estimate_video(video, models_dir=models)
    if cached:
        cache.mkdir(parents=True, exist_ok=True)
        track.save(cached)
    return track


def measure_camera(video: Path, truths: dict, models: Path, cache: Path | None, config: ReconstructionConfig) -> dict:
    track = pose_track(video, models, cache)
    started = time.perf_counter()
    motion = reconstruct_track(track, config, name=video.stem)
    seconds = time.perf_counter() - started
    flips = motion.extras["label_flipped"]
    fixed = undo_label_flips(observe(track), flips).points3d[:, :len(JOINT_KEYPOINTS)]
    predictions = {"raw": motion.extras["raw_keypoints3d"], "raw, labels fixed": fixed,
                   "reconstruction": motion.extras["keypoints3d"]}
    result = {"frames": motion.num_frames, "seconds": round(seconds, 2), "label_flips": int(flips.sum()),
              "reprojection_error_px": round(float(motion.extras["reprojection_error_px"].mean()), 2)}
    for truth_name, truth in truths.items():
        result[truth_name] = {name: {k: round(v, 2) for k, v in evaluate(p, truth, HIPS).items()}
                              for name, p in predictions.items()}
    return result


def markdown(results: dict, truth: str) -> str:
    rows = ["| camera | prediction | MPJPE mm | PA-MPJPE mm | accel err mm/frame^2 |", "|---|---|---|---|---|"]
    for camera, result in results.items():
        for name, values in result[truth].items():
            rows.append(f"| {camera} | {name} | {values['mpjpe_mm']:.1f} | {values['pa_mpjpe_mm']:.1f} | "
                        f"{values['accel_error_mm']:.1f} |")
    return "\n".join(rows)


def mean_over_cameras(results: dict, truth: str) -> dict:
    names = next(iter(results.values()))[truth].keys()
    return {name: {k: round(float(np.mean([r[truth][name][k] for r in results.values()])), 2)
                   for k in ("mpjpe_mm", "pa_mpjpe_mm", "accel_error_mm")} for name in names}




def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="the shared data folder")
    parser.add_argument("--pose-models", type=Path, default=None, help="BlazePose models (default: shared/models/blazepose)")
    parser.add_argument("--cameras", default="cam01,cam02,cam03,cam04", help="comma-separated camera videos to use")
    parser.add_argument("--iterations", type=int, default=ReconstructionConfig().iterations, help="reconstruction Adam steps")
    parser.add_argument("--track-cache", type=Path, default=None, help="keep pose tracks here and reuse them")
    parser.add_argument("--out", type=Path, default=None, help="write the results as JSON here")
    args = parser.parse_args()

    clip = args.shared / CLIP_DIR
    if not clip.is_dir():
        print(f"reconstruction_benchmark: {clip} not found (needs ../shared)", file=sys.stderr)
        return 2
    models = args.pose_models or args.shared / "models" / "blazepose"
    config = dataclasses.replace(ReconstructionConfig(), iterations=args.iterations)
    truths = {name: read_trc_markers(clip / file, JOINT_KEYPOINTS) for name, file in TRC_FILES.items()}
    floor = 1000.0 * acceleration_error(centre_on(truths["triangulated"], HIPS), centre_on(truths["filtered"], HIPS))
    results = {}
    for camera in args.cameras.split(","):
        results[camera] = measure_camera(clip / f"{camera}.mp4", truths, models, args.track_cache, config)
        print(f"{camera}: {results[camera]['seconds']} s, {results[camera]['label_flips']} label flips, "
              f"reprojection {results[camera]['reprojection_error_px']} px", file=sys.stderr)
    document = {"clip": str(CLIP_DIR), "iterations": args.iterations, "config": dataclasses.asdict(config),
                "gt_floor_accel_error_mm": round(floor, 2), "cameras": results,
                "mean": {truth: mean_over_cameras(results, truth) for truth in TRC_FILES}}
    for truth in TRC_FILES:
        print(f"\n### against the {truth} markers\n")
        print(markdown(results, truth))
        print("| mean | " + " |\n| mean | ".join(
            f"{name} | {v['mpjpe_mm']:.1f} | {v['pa_mpjpe_mm']:.1f} | {v['accel_error_mm']:.1f}"
            for name, v in document["mean"][truth].items()) + " |")
    print(f"\ngt floor: triangulated vs filtered markers differ by {floor:.1f} mm/frame^2 in acceleration")
    if args.out:
        atomic_write_json(args.out, document)
    return 0


if __name__ == "__main__":
    sys.exit(main())
