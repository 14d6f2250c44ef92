"""Does physics make a video motion better or worse? Each Pose2Sim camera alone, against the markers.

    python bench/scripts/physics_vs_kinematics.py --runs DIR [--cameras cam01,cam02,cam03,cam04] [--samples N]
                                          [--out bench/results/physics_vs_kinematics.json]

For each camera of ../shared/data/video/pose2sim_balancing (one person, 100 frames at 60 fps),
`sfv pipeline camNN.mp4 --out DIR/camNN --samples N` runs as a user runs it (pose, reconstruction,
training, then the controller from the clip's first frame: report.json, simulated.npz); a
camera whose DIR/camNN/report.json exists is measured as it is (`--finish-only` where only the
finishing step is missing). Three motions are then compared with the 12 joints triangulated from
all four cameras (`*.trc`, world = trc[:, [2, 0, 1]]), on the controller's 30 Hz grid (every
other video frame):

- raw: BlazePose's per-frame 3D prediction (its world landmarks placed in the world);
- kinematic: SFV's motion reconstruction (the reference the controller imitates);
- simulated: the controller's rollout from the clip's first frame (physics).

Columns: PA-MPJPE (a similarity per frame), MPJPE after one similarity for the clip (both
hip-centred per frame, as `bench/reconstruction_benchmark.py`), world MPJPE after one similarity
without hip-centring (the body's path counts), acceleration error (mm per 30 Hz frame^2, after
the clip's alignment), foot skating (m/s: the feet's horizontal speed while on the floor) and
ground penetration (m: the body's lowest point below the floor) from `services/pipeline/metrics.py`
for the two humanoid motions; the markers' own skating (lowest foot marker within 2 cm of that
foot's lowest height in the clip) is the ground truth's. Anchors: SimPoE (Human3.6M MPJPE 56.7 /
PA 41.6 mm) and PhysCap (97.4 / 65.1 mm) report physics improving plausibility at equal or better
accuracy. A run that fell is measured to the clip's end (the fall counts against it).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # run from a checkout without installing

from learner.atomic_io import atomic_write_json  # noqa: E402
from services.reconstruction import JOINT_KEYPOINTS  # noqa: E402
from services.reconstruction.metrics import clip_aligned, evaluate  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
CLIP_DIR = Path("data") / "video" / "pose2sim_balancing"
TRC = "S00_P00_T01_BalancingTrial_0-100.trc"
HIPS = [JOINT_KEYPOINTS.index("RHip"), JOINT_KEYPOINTS.index("LHip")]
FOOT_MARKERS = (("RHeel", "RBigToe", "RSmallToe"), ("LHeel", "LBigToe", "LSmallToe"))
MARKER_CONTACT_M = 0.02
ANCHORS = {"SimPoE (Human3.6M)": {"mpjpe_mm": 56.7, "pa_mpjpe_mm": 41.6},
           "PhysCap (Human3.6M)": {"mpjpe_mm": 97.4, "pa_mpjpe_mm": 65.1}}
MOTIONS = ("raw", "kinematic", "simulated")


def read_markers(path: Path) -> tuple[list[str], np.ndarray]:
    """Marker names and (T, M, 3) positions in the calibration's world frame (z up)."""
    lines = path.read_text().splitlines()
    names = [n for n in lines[3].split("\t")[2:] if n]
    rows = [line.split("\t") for line in lines[5:] if line.strip()]
    data = np.array([[float(v) for v in row[2:2 + 3 * len(names)]] for row in rows]).reshape(len(rows), -1, 3)
    return names, data[:, :, [2, 0, 1]]  # the .trc's axes are permuted against the calibration's


def marker_skating(names: list[str], markers: np.ndarray, rows: np.ndarray, hz: float) -> float | None:
    from services.pipeline.metrics import foot_skating

    feet = np.stack([markers[:, [names.index(n) for n in foot]].mean(axis=1) for foot in FOOT_MARKERS], axis=1)
    lowest = np.stack([markers[:, [names.index(n) for n in foot], 2].min(axis=1) for foot in FOOT_MARKERS], axis=1)
    contacts = lowest <= lowest.min(axis=0) + MARKER_CONTACT_M  # no one floor: a raised plate under one foot
    return foot_skating(feet[rows], contacts[rows], hz)


def run_pipeline(video: Path, out: Path, samples: int | None, models: Path, extra: list[str]) -> None:
    """`sfv pipeline` for one camera (or only its finishing step, when training is done)."""
    command = [sys.executable, "-m", "services.cli", "pipeline", str(video), "--out", str(out), "--quiet"]
    if (out / "motion.npz").is_file() and (out / "train" / "config.json").is_file():
        command.append("--finish-only")
    else:
        command += ["--pose-models", str(models), *([] if samples is None else ["--samples", str(samples)]), *extra]
    print(" ".join(command), file=sys.stderr)
    done = subprocess.run(command, cwd=REPO, text=True, stdout=subprocess.PIPE)
    if done.returncode != 0:
        raise SystemExit(f"physics_vs_kinematics: {video.name}: sfv pipeline failed (exit {done.returncode}); see {out}/sfv.log")


def measure(directory: Path, names: list[str], markers: np.ndarray) -> dict:
    from actors.motion.formats.io import load_motion
    from services.pipeline.report import video_rows

    report = json.loads((directory / "report.json").read_text())
    reconstruction = load_motion(str(directory / "motion.npz"))
    simulated = load_motion(str(directory / "simulated.npz"))
    hz = float(report["control_hz"])
    rows = video_rows(reconstruction, np.arange(simulated.num_frames) / hz)
    start = int(report.get("video_start_frame", 0))
    truth = markers[start + rows][:, [names.index(n) for n in JOINT_KEYPOINTS]]
    motions = {"raw": reconstruction.extras["raw_keypoints3d"][rows], "kinematic": reconstruction.extras["keypoints3d"][rows],
               "simulated": simulated.extras["keypoints3d"]}
    result = {"frames": int(simulated.num_frames), "fell": report["fell"], "fell_at_s": report["fell_at_s"],
              "normalized_return": report["normalized_return"], "samples": _samples(directory)}
    for name, points in motions.items():
        figures = {k: round(v, 1) for k, v in evaluate(points, truth, HIPS).items()}
        figures["world_mpjpe_mm"] = round(1000.0 * float(np.linalg.norm(clip_aligned(points, truth) - truth, axis=-1).mean()), 1)
        who = {"kinematic": "reference", "simulated": "simulated"}.get(name)
        figures["foot_skating_m_s"] = None if who is None else report["foot_skating_m_s"][who]
        figures["ground_penetration_m"] = None if who is None else report["ground_penetration_m"][who]
        result[name] = figures
    result["markers"] = {"foot_skating_m_s": marker_skating(names, markers, start + rows, hz)}
    return result


def _samples(directory: Path) -> int | None:
    metrics = directory / "train" / "metrics.jsonl"
    if not metrics.is_file():
        return None
    lines = [line for line in metrics.read_text().splitlines() if line.strip()]
    return json.loads(lines[-1]).get("samples") if lines else None


def markdown(results: dict) -> str:
    rows = ["| camera | motion | PA-MPJPE mm | MPJPE mm | world MPJPE mm | accel. err mm/frame² | skating m/s | penetration mm |",
            "|---|---|---|---|---|---|---|---|"]
    for camera, result in results.items():
        for name in MOTIONS:
            v = result[name]
            skate = "-" if v["foot_skating_m_s"] is None else f"{v['foot_skating_m_s']:.3f}"
            depth = "-" if v["ground_penetration_m"] is None else f"{1000 * v['ground_penetration_m']['max']:.1f}"
            label = name + (f" (fell at {result['fell_at_s']:.2f} s)" if name == "simulated" and result["fell"] else "")
            rows.append(f"| {camera} | {label} | {v['pa_mpjpe_mm']:.1f} | {v['mpjpe_mm']:.1f} | {v['world_mpjpe_mm']:.1f} | "
                        f"{v['accel_error_mm']:.1f} | {skate} | {depth} |")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, required=True, help="one pipeline output directory per camera: RUNS/camNN")
    parser.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="the shared data folder")
    parser.add_argument("--pose-models", type=Path, default=None, help="BlazePose models (default: shared/models/blazepose)")
    parser.add_argument("--cameras", default="cam01,cam02,cam03,cam04", help="comma-separated camera videos")
    parser.add_argument("--samples", type=int, default=None, help="training budget per camera (default: the pipeline's)")
    parser.add_argument("--out", type=Path, default=None, help="write the results as JSON here (bench/results/...)")
    args, extra = parser.parse_known_args(argv)  # anything else goes to `sfv pipeline` (e.g. --workers 2)

    clip = args.shared / CLIP_DIR
    if not (clip / TRC).is_file():
        print(f"physics_vs_kinematics: {clip / TRC} not found (needs ../shared)", file=sys.stderr)
        return 2
    models = args.pose_models or args.shared / "models" / "blazepose"
    names, markers = read_markers(clip / TRC)
    results = {}
    for camera in args.cameras.split(","):
        directory = args.runs / camera
        if not (directory / "report.json").is_file():
            run_pipeline(clip / f"{camera}.mp4", directory, args.samples, models, extra)
        results[camera] = measure(directory, names, markers)
    means = {name: {k: round(float(np.mean([r[name][k] for r in results.values()])), 1)
                    for k in ("pa_mpjpe_mm", "mpjpe_mm", "world_mpjpe_mm", "accel_error_mm")} for name in MOTIONS}
    document = {"clip": str(CLIP_DIR), "truth": TRC, "grid_hz": 30.0, "cameras": results, "mean": means,
                "upright_from_first_frame": sum(not r["fell"] for r in results.values()), "anchors": ANCHORS}
    print(markdown(results))
    if args.out:
        atomic_write_json(args.out, document)
    return 0


if __name__ == "__main__":
    sys.exit(main())
