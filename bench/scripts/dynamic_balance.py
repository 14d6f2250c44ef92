"""Can a body balance the way the reference moves? Issue 44: the static balance term against the dynamic one.

    python bench/scripts/dynamic_balance.py [--runs RUNS] [--shared ../shared] [--modes static:50,dynamic:50]
                                            [--extra TRACK.npz ...] [--mocap deepmimic:walk,deepmimic:jump]
                                            [--out bench/results/dynamic_balance.json]

A body on its feet moves its centre of mass only as the ground's reaction lets it: the reaction acts
inside the support, at the zero-moment point (`services/reconstruction/losses.py` `zero_moment_point`).
A reference whose zero-moment point lies far outside the support asks for a force no foot can give,
which a controller takes from the residual root force. Per reference, over the frames whose contacts
have a foot down and whose acceleration (0.1 s either side) exists:

- zmp_cm / zmp_over_5cm: the zero-moment point's median distance from the support, and the share of
  frames where it lies more than 5 cm out; static_cm: the centre of mass's own (what the static term
  charges); body_zmp_cm / _p90_cm / _mean_cm: the whole body's zero-moment point (every link's mass
  and acceleration, the spin about the centre of mass included; `whole_body_zero_moment_point`),
  median, 90th percentile and mean;
- com_accel_m_s2: the centre of mass's median horizontal acceleration;
- flight_cm (frames with no foot down): the median departure from a free fall, as a lever
  (`losses.flight_deviation`);
- hip_accel_m_s2 (Pose2Sim cameras): the hip midpoint's median horizontal acceleration on the
  controller's 30 Hz grid, of the reconstruction and of the triangulated markers (truth);
- the accuracy against the markers as `focal_effect.py` scores it (PA-MPJPE, MPJPE, acceleration
  error, reprojection).

Each pipeline run RUNS/<trial>_camNN/ with a `track.npz` (and each `--extra` track, a video without
markers) is reconstructed as the pipeline does it (`services/contacts/video_motion.py`) once per
MODE:WEIGHT (`ReconstructionConfig.balance`, `w_balance`; MODE `dynamic-flight` or `whole_body-flight` adds
`balance_flight`). `--mocap` clips (contacts where a sole is
within 4 cm of the clip's floor) show what a motion a body performed gives.
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

from bench.scripts.focal_effect import calibrated_runs, grid_rows, measure  # noqa: E402

RESULT = REPO / "bench" / "results" / "dynamic_balance.json"
WINDOW_S = 0.1  # seconds either side for the accelerations measured (the term's default)
MOCAP_CONTACT_M = 0.04


def balance_figures(motion, contacts: np.ndarray) -> dict:
    """The zero-moment point's and the centre of mass's distances from the support, and the centre of
    mass's horizontal acceleration, over the frames with a foot down and a central difference."""
    import torch

    from services.reconstruction.body import LINK_MASS_FRACTIONS, body_points
    from services.reconstruction.losses import (
        centre_acceleration,
        flight_deviation,
        support_distance,
        whole_body_zero_moment_point,
        zero_moment_point,
    )
    from services.reconstruction.reconstruct import HEEL_POINTS, TOE_POINTS

    with torch.no_grad():
        fit, _, com, centres = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot),
                                           torch.as_tensor(motion.joint_rot), with_links=True)
        fit, com, centres = fit.double(), com.double(), centres.double()
        k = max(1, int(round(WINDOW_S * float(motion.fps))))
        accel = centre_acceleration(com, float(motion.fps), k)
        zmp = zero_moment_point(com[k:-k], accel, 0.0)
        body_zmp = whole_body_zero_moment_point(centres[k:-k], torch.as_tensor(LINK_MASS_FRACTIONS),
                                                centre_acceleration(centres, float(motion.fps), k), 0.0)
        down = torch.as_tensor(np.asarray(contacts, float))
        heels, toes = fit[:, HEEL_POINTS, :2], fit[:, TOE_POINTS, :2]
        static = support_distance(com[:, :2], heels, toes, down).numpy()[k:-k]
        dynamic = support_distance(zmp, heels[k:-k], toes[k:-k], down[k:-k]).numpy()
        whole = support_distance(body_zmp, heels[k:-k], toes[k:-k], down[k:-k]).numpy()
        flight = flight_deviation(com[k:-k], accel, 0.0).numpy()
    rows = np.asarray(contacts, bool)[k:-k].any(axis=-1)
    if not rows.any():
        return {"frames": 0}
    horizontal = np.linalg.norm(accel.numpy()[rows, :2], axis=-1)
    airborne = {"airborne_frames": int((~rows).sum()), "flight_cm": round(100 * float(np.median(flight[~rows])), 1)} if (~rows).any() else {}
    return {**airborne, "frames": int(rows.sum()), "zmp_cm": round(100 * float(np.median(dynamic[rows])), 1),
            "zmp_over_5cm": round(float((dynamic[rows] > 0.05).mean()), 2),
            "body_zmp_cm": round(100 * float(np.median(whole[rows])), 1),
            "body_zmp_p90_cm": round(100 * float(np.percentile(whole[rows], 90)), 1),
            "body_zmp_mean_cm": round(100 * float(whole[rows].mean()), 1),
            "static_cm": round(100 * float(np.median(static[rows])), 1),
            "com_accel_m_s2": round(float(np.median(horizontal)), 2)}


def hip_acceleration(points: np.ndarray, hz: float) -> float:
    """Median horizontal acceleration (m/s^2) of the hip midpoint of 12-joint points (F, 12, 3), z up."""
    from services.reconstruction import JOINT_KEYPOINTS

    hips = points[:, [JOINT_KEYPOINTS.index("RHip"), JOINT_KEYPOINTS.index("LHip")]].mean(axis=1)
    k = max(1, int(round(WINDOW_S * hz)))
    accel = (hips[2 * k:] - 2 * hips[k:-k] + hips[:-2 * k]) * (hz / k) ** 2
    return round(float(np.median(np.linalg.norm(accel[:, :2], axis=-1))), 2)


def truth_hip_acceleration(video: Path, motion) -> dict:
    from bench.scripts.focal_effect import GRID_HZ
    from services.bench.videos_truth import followed_truth

    rows = grid_rows(motion)
    frames = int(motion.extras.get("video_start_frame", 0)) + rows
    found = followed_truth(video, np.asarray(motion.extras["keypoints2d"])[rows], frames)
    points = np.asarray(motion.extras["keypoints3d"])[rows]
    result = {"hip_accel_m_s2": hip_acceleration(points, GRID_HZ)}
    if found is not None and np.isfinite(found[1]).all():
        result["true_hip_accel_m_s2"] = hip_acceleration(found[1], GRID_HZ)
    return result


def reconstruct(track, mode: str, weight: float, name: str, source: str):
    from services.contacts.video_motion import video_motion
    from services.reconstruction import ReconstructionConfig

    balance, _, flight = mode.partition("-")  # dynamic-flight: the flight term too
    config = dataclasses.replace(ReconstructionConfig(), balance=balance, balance_flight=flight == "flight", w_balance=weight)
    return video_motion(track, config, name, "static", source, use_ray=False).motion


def mocap_figures(name: str) -> dict:
    from actors.motion.formats.io import load_motion
    from services.reconstruction.body import motion_foot_corners

    motion = load_motion(name)
    soles = motion_foot_corners(motion.root_pos, motion.root_rot, motion.joint_rot)[..., 2].min(axis=-1)
    contacts = soles - np.percentile(soles, 2) < MOCAP_CONTACT_M
    return balance_figures(motion, contacts)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, default=None, help="pipeline run directories RUNS/<trial>_camNN/ with track.npz")
    parser.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="the shared data folder")
    parser.add_argument("--modes", default="static:50,dynamic:50", help="MODE:WEIGHT, comma-separated")
    parser.add_argument("--extra", type=Path, nargs="*", default=[], help="pose tracks without markers (runs, walks)")
    parser.add_argument("--mocap", default="deepmimic:walk,deepmimic:jump", help="motion clips, comma-separated ('' for none)")
    parser.add_argument("--out", type=Path, default=RESULT, help="the JSON written")
    args = parser.parse_args(argv)

    import torch

    from learner.atomic_io import atomic_write_json
    from services.bench.videos_truth import CALIBRATION, camera_key
    from services.pose import PoseTrack

    torch.set_num_threads(1)
    modes = [(m, float(w)) for m, w in (item.split(":") for item in args.modes.split(","))]
    mocap = {name: mocap_figures(name) for name in filter(None, args.mocap.split(","))}
    for name, figures in mocap.items():
        print(name, figures, flush=True)
    cameras, extras = {}, {}
    for run, video in (calibrated_runs(args.runs, args.shared, "dynamic_balance") if args.runs else []):
        calibration = tomllib.loads((video.parent / CALIBRATION).read_text())[camera_key(video)]
        track = PoseTrack.load(run / "track.npz")
        for mode, weight in modes:
            motion = reconstruct(track, mode, weight, video.stem, str(video))
            result = {**measure(video, motion, calibration), **balance_figures(motion, motion.extras["contacts"]),
                      **truth_hip_acceleration(video, motion)}
            cameras.setdefault(run.name, {})[f"{mode}:{weight:g}"] = result
            print(run.name, mode, weight, {k: result.get(k) for k in ("pa_mpjpe_mm", "accel_error_mm", "reprojection_px", "zmp_cm",
                                                                       "body_zmp_cm", "body_zmp_p90_cm",
                                                                       "com_accel_m_s2", "hip_accel_m_s2", "true_hip_accel_m_s2")}, flush=True)
    for path in args.extra:
        track = PoseTrack.load(path)
        for mode, weight in modes:
            motion = reconstruct(track, mode, weight, path.stem, str(path))
            error = float(np.asarray(motion.extras["reprojection_error_px"]).mean())
            figures = {"reprojection_px": round(error, 1), **balance_figures(motion, motion.extras["contacts"])}
            extras.setdefault(str(path), {})[f"{mode}:{weight:g}"] = figures
            print(path, mode, weight, figures, flush=True)
    keys = ("pa_mpjpe_mm", "mpjpe_mm", "accel_error_mm", "reprojection_px", "zmp_cm", "body_zmp_cm", "body_zmp_p90_cm",
            "body_zmp_mean_cm", "com_accel_m_s2", "hip_accel_m_s2")
    means = {f"{m}:{w:g}": {k: round(float(np.mean([c[f"{m}:{w:g}"][k] for c in cameras.values()])), 2) for k in keys}
             for m, w in modes} if cameras else {}
    truths = [c[next(iter(c))].get("true_hip_accel_m_s2") for c in cameras.values()]
    atomic_write_json(args.out, {"what": __doc__.split("\n\n")[0], "window_s": WINDOW_S, "mocap": mocap, "cameras": cameras,
                                 "mean": means, "true_hip_accel_m_s2_mean": round(float(np.mean([t for t in truths if t is not None])), 2)
                                 if any(t is not None for t in truths) else None, "extra": extras})
    return 0


if __name__ == "__main__":
    sys.exit(main())
