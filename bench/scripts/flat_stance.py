"""Does a weight-bearing foot stand on its sole? The reconstruction's flat-stance term (issue 44).

    python bench/scripts/flat_stance.py [--runs /tmp/v44/suite_runs] [--park RUN] [--weights 0,10,100]
                                        [--out bench/results/flat_stance.json]

On the Sports2D park walk (`services/bench/public_videos.py`) the reconstruction put the right
foot of the walker on the tips of its toes through the second half of every stance: heel 9-15 cm
above toe in the frames the contact estimator says the foot is down, while the video's heel and
toe keypoints show a flat foot. The 3D prediction's ankle rotation (l3d, weight 100) wins over the
two 2D foot points (weight 0.5 each). A body cannot stand on that; the helped controller leaned
on the residual root force for 12 % of body weight and fell at 2.1 s without it.
`ReconstructionConfig.w_flat` charges the squared heel-to-toe height of a foot in contact.

Each saved pose track (the pipeline's `track.npz`) is reconstructed as the pipeline does it
(`services/contacts/video_motion.py`) at each weight, and measured:
- stance tilt: |toe - heel| height (cm) of the feet in contact, mean and 90th percentile;
- reprojection (px, the fit's own camera);
- on the Pose2Sim cameras: PA-MPJPE, MPJPE and acceleration error against the followed person's
  markers (`bench/scripts/focal_effect.py` `measure`, 30 Hz grid).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from bench.scripts.focal_effect import RUNS, camera_runs, measure  # noqa: E402

RESULT = REPO / "bench" / "results" / "flat_stance.json"


def stance_tilt_cm(motion) -> dict:
    import torch

    from services.reconstruction.body import body_points
    from services.reconstruction.keypoints import fit_index

    fit, _ = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot), torch.as_tensor(motion.joint_rot))
    fit = fit.double().numpy()
    toes, heels = [fit_index("RToe"), fit_index("LToe")], [fit_index("RHeel"), fit_index("LHeel")]
    rise = np.abs(fit[:, toes, 2] - fit[:, heels, 2])[np.asarray(motion.extras["contacts"], bool)] * 100.0
    return {"stance_tilt_cm": round(float(rise.mean()), 2), "stance_tilt_p90_cm": round(float(np.percentile(rise, 90)), 2)}


def reconstruct(track_path: Path, video: Path | None, weight: float) -> dict:
    import tomllib

    from services.contacts.video_motion import video_motion
    from services.pose import PoseTrack
    from services.reconstruction import ReconstructionConfig

    track = PoseTrack.load(track_path)
    started = time.time()
    made = video_motion(track, dataclasses.replace(ReconstructionConfig(), w_flat=weight), track_path.parent.name,
                        "static", str(track_path), use_ray=False)
    motion = made.motion
    row = {"w_flat": weight, **stance_tilt_cm(motion),
           "reprojection_px": round(float(np.asarray(motion.extras["reprojection_error_px"]).mean()), 1),
           "seconds": round(time.time() - started, 1), "reference_check": made.check}
    if video is not None:
        from services.bench.videos_truth import CALIBRATION, camera_key
        calibration = tomllib.loads((video.parent / CALIBRATION).read_text())[camera_key(video)]
        truth = measure(video, motion, calibration)
        row.update({k: truth[k] for k in ("pa_mpjpe_mm", "mpjpe_mm", "accel_error_mm")})
    return row


def markdown(result: dict) -> str:
    lines = ["| track | w_flat | stance tilt cm, mean / p90 | reprojection px | PA-MPJPE mm | MPJPE mm | accel. mm/frame² |",
             "|---|---:|---|---:|---:|---:|---:|"]
    for name, rows in result["tracks"].items():
        for r in rows:
            lines.append(f"| {name} | {r['w_flat']:g} | {r['stance_tilt_cm']:.1f} / {r['stance_tilt_p90_cm']:.1f} | "
                         f"{r['reprojection_px']:.1f} | {r.get('pa_mpjpe_mm', '-')} | {r.get('mpjpe_mm', '-')} | "
                         f"{r.get('accel_error_mm', '-')} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    from learner.atomic_io import atomic_write_json

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, default=RUNS, help="Pose2Sim pipeline runs RUNS/<trial>_camNN/track.npz")
    parser.add_argument("--videos", type=Path, default=REPO.parent / "shared" / "data" / "video")
    parser.add_argument("--park", type=Path, default=None, help="a pipeline run of the park walk (its track.npz)")
    parser.add_argument("--weights", default="0,10,100")
    parser.add_argument("--out", type=Path, default=RESULT)
    args = parser.parse_args(argv)
    weights = [float(w) for w in args.weights.split(",")]
    jobs = [(run.name, run / "track.npz", video) for run, video in camera_runs(args.runs, args.videos)]
    if args.park is not None:
        jobs.insert(0, ("sports2d_demo (park walk)", args.park / "track.npz", None))
    result = {"weights": weights, "tracks": {}}
    for name, track, video in jobs:
        result["tracks"][name] = [reconstruct(track, video, w) for w in weights]
        for row in result["tracks"][name]:
            print(name, row, flush=True)
        atomic_write_json(args.out, result)
    print(markdown(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
