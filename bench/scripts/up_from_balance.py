"""Which way is up? The body's axis against balance, on the calibrated Pose2Sim cameras (issue 44).

    python bench/scripts/up_from_balance.py --runs RUNS [--shared ../shared]
                                           [--out bench/results/up_from_balance.json]

The static reconstruction fixes the world's up direction once, before it fits anything
(`services/reconstruction/camera.py`). It used to take it from the 3D prediction's mean
ankle-to-shoulder axis (`estimate_up`); with `up_from_balance` (the default) it turns that to the
mean direction from the feet down to the centre of mass (`balance_up`). Each pipeline run directory
RUNS/<trial>_camNN/ with a `track.npz` is reconstructed with both, as the pipeline does it
(`services/contacts/video_motion.py`: static camera, learned contacts, the reference check), and
measured against the calibration and the markers of the person followed:

- up_error_deg: the angle between the reconstruction's up and the calibration's vertical (the
  Qualisys world's z), both in camera axes; pitch_deg / true_pitch_deg: how far the camera looks
  below the horizontal;
- com_support_cm: the centre of mass's mean horizontal distance from the support of the feet down
  (`losses.support_distance`: 0 inside the feet's soles), over the frames a foot is down: how far the
  reference stands from a balance a body could hold;
- PA-MPJPE, MPJPE, acceleration error (mm) and the camera's height, as `focal_effect.py` measures them.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from bench.scripts.focal_effect import calibrated_runs, calibration_camera, measure  # noqa: E402

RESULT = REPO / "bench" / "results" / "up_from_balance.json"


def support_cm(motion) -> float:
    """Mean horizontal distance (cm) of the motion's centre of mass from its support, frames with a foot down."""
    import torch

    from services.reconstruction.body import body_points
    from services.reconstruction.keypoints import FIT_NAMES
    from services.reconstruction.losses import support_distance

    contacts = np.asarray(motion.extras["contacts"], bool)
    with torch.no_grad():
        fit, _, com = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot),
                                  torch.as_tensor(motion.joint_rot), with_com=True)
        heels = fit[:, [FIT_NAMES.index("RHeel"), FIT_NAMES.index("LHeel")]]
        toes = fit[:, [FIT_NAMES.index("RToe"), FIT_NAMES.index("LToe")]]
        distance = support_distance(com[..., :2], heels[..., :2], toes[..., :2], torch.as_tensor(contacts, dtype=com.dtype))
    down = contacts.any(axis=1)
    return float(distance.double().numpy()[down].mean() * 100) if down.any() else float("nan")


def up_error(motion, calibration: dict) -> dict:
    import cv2

    from bench.scripts.focal_effect import pitch_deg

    rotation = np.asarray(motion.extras["camera_rotation"], np.float64)
    true_rotation, _ = cv2.Rodrigues(np.asarray(calibration["rotation"], np.float64))
    cosine = float(np.clip(rotation[:, 2] @ true_rotation[:, 2], -1.0, 1.0))
    return {"up_error_deg": round(float(np.degrees(np.arccos(cosine))), 1), "pitch_deg": round(pitch_deg(rotation), 1),
            "true_pitch_deg": round(pitch_deg(true_rotation), 1)}


def camera_result(run: Path, video: Path) -> dict:
    from services.bench.videos_truth import CALIBRATION, camera_key
    from services.contacts.video_motion import video_motion
    from services.pose import PoseTrack
    from services.reconstruction import ReconstructionConfig

    calibration = tomllib.loads((video.parent / CALIBRATION).read_text())[camera_key(video)]
    track = PoseTrack.load(run / "track.npz")
    result = {"video": f"{video.parent.name}/{video.name}", "person_id": int(track.person_id),
              "true_camera_height_m": round(calibration_camera(calibration)["height_m"], 3)}
    for name, balance in (("body_axis", False), ("balance", True)):
        started = time.time()
        config = dataclasses.replace(ReconstructionConfig(), up_from_balance=balance)
        made = video_motion(track, config, video.stem, "static", str(video), use_ray=False)
        result[name] = {**up_error(made.motion, calibration), "com_support_cm": round(support_cm(made.motion), 1),
                        **measure(video, made.motion, calibration), "seconds": round(time.time() - started, 1),
                        "reference_check": made.check}
        print(video.parent.name, video.stem, name, {k: result[name][k] for k in
              ("up_error_deg", "pitch_deg", "true_pitch_deg", "com_support_cm", "pa_mpjpe_mm", "mpjpe_mm", "accel_error_mm",
               "camera_height_m")}, flush=True)
    return result


def markdown(cameras: dict) -> str:
    lines = ["| camera | up | up error ° | pitch ° (calib.) | CoM from support cm | PA-MPJPE mm | MPJPE mm | accel. mm/frame² | camera height m (calib.) |",
             "|---|---|---:|---|---:|---:|---:|---:|---|"]
    for key, result in cameras.items():
        for name in ("body_axis", "balance"):
            v = result[name]
            lines.append(f"| {key} | {name.replace('_', ' ')} | {v['up_error_deg']:.1f} | {v['pitch_deg']:.1f} ({v['true_pitch_deg']:.1f}) | "
                         f"{v['com_support_cm']:.1f} | {v['pa_mpjpe_mm']:.1f} | {v['mpjpe_mm']:.1f} | {v['accel_error_mm']:.1f} | "
                         f"{v['camera_height_m']:.2f} ({result['true_camera_height_m']:.2f}) |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, required=True, help="pipeline run directories RUNS/<trial>_camNN/ with track.npz")
    parser.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="the shared data folder")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (the machine is shared)")
    parser.add_argument("--out", type=Path, default=RESULT, help="the JSON written")
    args = parser.parse_args(argv)

    import torch

    from learner.atomic_io import atomic_write_json

    torch.set_num_threads(args.threads)
    found = calibrated_runs(args.runs, args.shared, "up_from_balance")
    if not found:
        return 2
    cameras = {run.name: camera_result(run, video) for run, video in found}
    table = markdown(cameras)
    print(table)
    mean = {name: {k: round(float(np.mean([c[name][k] for c in cameras.values()])), 2)
                   for k in ("up_error_deg", "com_support_cm", "pa_mpjpe_mm", "mpjpe_mm", "accel_error_mm")}
            for name in ("body_axis", "balance")}
    atomic_write_json(args.out, {
        "what": "issue 44: the reconstruction's up direction from the body's axis against balance (up_from_balance), "
                "on the calibrated Pose2Sim cameras: up error against the calibration, centre of mass from the support, "
                "joint errors against the markers (python bench/scripts/up_from_balance.py)",
        "cameras": cameras, "mean": mean, "table": table})
    return 0


if __name__ == "__main__":
    sys.exit(main())
