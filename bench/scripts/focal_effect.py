"""Does the reconstruction's default focal length cost accuracy? Issue 44, on calibrated Pose2Sim cameras.

    python bench/scripts/focal_effect.py [--runs /tmp/v44/suite_runs] [--shared ../shared]
                                         [--out bench/results/focal_effect.json]

The static reconstruction assumes a focal length of max(image width, height) (1920 px on the
Pose2Sim videos; `services/reconstruction/camera.py` `default_focal`); the Qualisys calibration
of these cameras says 1,674-1,682 px (`Calib_qualisys.toml`, `matrix`: the mean of f_x and f_y).
Each pipeline run directory RUNS/<trial>_camNN/ with a `track.npz` (the pose track `sfv
pipeline` saved, already following its subject) is reconstructed twice with the same track, as
the pipeline does it (`services/contacts/video_motion.py`: static camera, learned contacts, the
reference check), once at the default focal and once at the calibration's; the run's own
`motion.npz` is measured beside them ("pipeline": the default, as it was run). Against the
triangulated markers of the person followed (`services/bench/videos_truth.py` `followed_truth`),
on the controller's 30 Hz grid as `bench/results/videos.json`:

- PA-MPJPE, MPJPE after one similarity, acceleration error (mm; hip-centred,
  `services/reconstruction/metrics.py` `evaluate`): the body's shape and motion;
- camera_height_m: the reconstruction's camera above its ground, and the calibration's camera
  above the lab floor (z = 0 of the calibration's world);
- camera_pitch_deg: how far the camera looks below the horizontal (the reconstruction's up
  direction comes from the body's mean axis), reconstructed and calibrated;
- depth_m: the mean depth of the hip midpoint in front of the camera (along its optical axis),
  the reconstruction's through its camera, the markers' through the calibration;
- hip_path_m: the length of the hip midpoint's path over the grid, reconstructed and markers;
- reprojection_px: the mean confidence-weighted 2D error of the fit (its own camera).
"""
from __future__ import annotations

import argparse
import dataclasses
import re
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

RESULT = REPO / "bench" / "results" / "focal_effect.json"
RUNS = Path("/tmp/v44/suite_runs")
GRID_HZ = 30.0
RUN_NAME = re.compile(r"(?P<trial>.+)_(?P<camera>cam\d+)")


def calibration_camera(calibration: dict) -> dict:
    """The focal length (px, mean of f_x and f_y), principal point (px), camera centre in the
    calibration's world (m; p_cam = R p + t, so centre = -R^T t) and its height (z) of one
    camera's section of `Calib_qualisys.toml`."""
    import cv2

    matrix = np.asarray(calibration["matrix"], np.float64)
    rotation, _ = cv2.Rodrigues(np.asarray(calibration["rotation"], np.float64))
    centre = -rotation.T @ np.asarray(calibration["translation"], np.float64)
    return {"focal_px": float((matrix[0, 0] + matrix[1, 1]) / 2.0), "principal_px": [float(matrix[0, 2]), float(matrix[1, 2])],
            "position_m": centre.tolist(), "height_m": float(centre[2]), "pitch_deg": pitch_deg(rotation)}


def pitch_deg(rotation: np.ndarray) -> float:
    """How far (degrees) the optical axis of a camera with this world -> camera rotation looks below
    the horizontal (world z up)."""
    return float(np.degrees(np.arcsin(np.clip(-rotation[2, 2], -1.0, 1.0))))


def depths(points: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """Depth (m, along the optical axis) of world points (..., 3) in front of a camera whose
    world -> camera rotation and centre are given."""
    return ((points - position) @ rotation.T)[..., 2]


def path_length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=-1).sum())


def grid_rows(motion, hz: float = GRID_HZ) -> np.ndarray:
    """The motion's rows on the controller's grid over the clip (the rows `truth_errors` scores)."""
    from services.pipeline.report import video_rows

    count = int(np.floor(motion.num_frames / motion.fps * hz + 1e-9)) + 1
    return video_rows(motion, np.arange(count) / hz)


def measure(video: Path, motion, calibration: dict) -> dict:
    """The motion's errors and world quantities against the followed person's markers."""
    import cv2

    from services.bench.videos_truth import followed_truth
    from services.reconstruction import JOINT_KEYPOINTS
    from services.reconstruction.metrics import evaluate

    rows = grid_rows(motion)
    frames = int(motion.extras.get("video_start_frame", 0)) + rows
    found = followed_truth(video, np.asarray(motion.extras["keypoints2d"])[rows], frames)
    if found is None:
        raise SystemExit(f"focal_effect: {video}: no markers or calibration for this camera")
    path, truth = found
    whole = np.isfinite(truth).all(axis=(1, 2))
    hips = [JOINT_KEYPOINTS.index("RHip"), JOINT_KEYPOINTS.index("LHip")]
    points = np.asarray(motion.extras["keypoints3d"])[rows][whole]
    truth = truth[whole]
    errors = {k: round(v, 1) for k, v in evaluate(points, truth, hips).items()}
    hip_fit, hip_true = points[:, hips].mean(axis=1), truth[:, hips].mean(axis=1)
    true_rotation, _ = cv2.Rodrigues(np.asarray(calibration["rotation"], np.float64))
    true_centre = np.asarray(calibration_camera(calibration)["position_m"])
    position = np.asarray(motion.extras["camera_position"], np.float64)
    return {
        "trc": path.name, "frames": int(whole.sum()),
        "focal_px": round(float(np.asarray(motion.extras["camera_intrinsics"])[0, 0]), 1),
        **errors,
        "camera_height_m": round(float(position[2]), 3),
        "camera_pitch_deg": round(pitch_deg(np.asarray(motion.extras["camera_rotation"], np.float64)), 1),
        "depth_m": round(float(depths(hip_fit, np.asarray(motion.extras["camera_rotation"]), position).mean()), 3),
        "true_depth_m": round(float(depths(hip_true, true_rotation, true_centre).mean()), 3),
        "hip_path_m": round(path_length(hip_fit), 3),
        "true_hip_path_m": round(path_length(hip_true), 3),
        "reprojection_px": round(float(np.asarray(motion.extras["reprojection_error_px"]).mean()), 1),
    }


def camera_runs(runs: Path, videos: Path) -> list[tuple[Path, Path]]:
    """(run directory, video) of every RUNS/<trial>_camNN/track.npz whose video lies in VIDEOS/<trial>/."""
    found = []
    for track in sorted(runs.glob("*/track.npz")):
        match = RUN_NAME.fullmatch(track.parent.name)
        video = videos / match["trial"] / f"{match['camera']}.mp4" if match else None
        if video is not None and video.is_file():
            found.append((track.parent, video))
    return found


def calibrated_runs(runs: Path, shared: Path, script: str) -> list[tuple[Path, Path]]:
    """`camera_runs` under RUNS with their videos in SHARED/data/video; says why on stderr when none."""
    found = camera_runs(runs, shared / "data" / "video")
    if not found:
        print(f"{script}: no RUNS/<trial>_camNN/track.npz under {runs} with its video in {shared / 'data' / 'video'}",
              file=sys.stderr)
    return found


def camera_result(run: Path, video: Path, iterations: int | None) -> dict:
    from actors.motion.formats.io import load_motion
    from services.bench.videos_truth import CALIBRATION, camera_key
    from services.contacts.video_motion import video_motion
    from services.pose import PoseTrack
    from services.reconstruction import ReconstructionConfig

    calibration = tomllib.loads((video.parent / CALIBRATION).read_text())[camera_key(video)]
    camera = calibration_camera(calibration)
    track = PoseTrack.load(run / "track.npz")
    config = ReconstructionConfig()
    if iterations is not None:
        config = dataclasses.replace(config, iterations=iterations)
    result = {"video": f"{video.parent.name}/{video.name}", "person_id": int(track.person_id),
              "image_size": [int(v) for v in track.image_size],
              "calibration": {k: (round(v, 3) if isinstance(v, float) else [round(x, 3) for x in v]) for k, v in camera.items()}}
    if (run / "motion.npz").is_file():
        result["pipeline"] = measure(video, load_motion(run / "motion.npz"), calibration)
    for name, focal in (("default", 0.0), ("calibrated", camera["focal_px"])):
        started = time.time()
        made = video_motion(track, dataclasses.replace(config, focal_length_px=focal), video.stem, "static", str(video),
                            use_ray=False)
        result[name] = {**measure(video, made.motion, calibration), "seconds": round(time.time() - started, 1),
                        "reference_check": made.check}
        print(video.parent.name, video.stem, name, result[name], flush=True)
    return result


def markdown(cameras: dict) -> str:
    lines = ["| camera | focal px | PA-MPJPE mm | MPJPE mm | accel. mm/frame² | camera height m (calib.) | "
             "pitch deg (calib.) | hip depth m (markers) | hip path m (markers) | reprojection px |",
             "|---|---:|---:|---:|---:|---|---|---|---|---:|"]
    for key, result in cameras.items():
        for name in ("default", "calibrated"):
            v = result[name]
            lines.append(f"| {key} | {v['focal_px']:.0f} | {v['pa_mpjpe_mm']:.1f} | {v['mpjpe_mm']:.1f} | "
                         f"{v['accel_error_mm']:.1f} | {v['camera_height_m']:.2f} ({result['calibration']['height_m']:.2f}) | "
                         f"{v['camera_pitch_deg']:.1f} ({result['calibration']['pitch_deg']:.1f}) | "
                         f"{v['depth_m']:.2f} ({v['true_depth_m']:.2f}) | {v['hip_path_m']:.2f} ({v['true_hip_path_m']:.2f}) | "
                         f"{v['reprojection_px']:.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, default=RUNS, help="pipeline run directories RUNS/<trial>_camNN/ with track.npz")
    parser.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="the shared data folder")
    parser.add_argument("--iterations", type=int, default=None, help="reconstruction Adam steps (default: the pipeline's)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (the machine is shared)")
    parser.add_argument("--out", type=Path, default=RESULT, help="the JSON written")
    args = parser.parse_args(argv)

    import torch

    from learner.atomic_io import atomic_write_json

    torch.set_num_threads(args.threads)
    found = calibrated_runs(args.runs, args.shared, "focal_effect")
    if not found:
        return 2
    cameras = {f"{run.name}": camera_result(run, video, args.iterations) for run, video in found}
    print(markdown(cameras))
    atomic_write_json(args.out, {
        "what": "issue 44: the reconstruction at the default focal (max(width, height)) and at the calibration's, "
                "same pose track, against the markers of the person followed (30 Hz grid)",
        "grid_hz": GRID_HZ, "runs": str(args.runs), "cameras": cameras})
    print(f"-> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
