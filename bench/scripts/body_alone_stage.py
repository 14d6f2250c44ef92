"""Can the body alone follow what the helped body did? Issue 44: a second stage after `sfv pipeline`.

    python bench/scripts/body_alone_stage.py RUN --out DIR [--samples 2000000] [--seed 0]

`sfv pipeline` trains its controller with a residual root wrench (the help): the reconstruction is
not a motion the body alone can perform, and most controllers fall once the help is taken away
(`report.json` `without_residual_force`). The helped rollout from the first frame (`RUN/simulated.npz`)
is a motion the simulated body did perform, apart from the help's push, with no foot skating and no
limb shaking in depth. This script makes it the reference of a second training, without help:

1. DIR/motion.npz: the reconstruction RUN/motion.npz (its camera, keypoints and contacts, which the
   report reads) with its poses replaced by the helped rollout's, frame for frame;
2. `sfv train --motion DIR/motion.npz --env.residual-force 0` at the pipeline's other defaults
   (`--samples`, the first frame's share of the starts);
3. `sfv pipeline VIDEO --out DIR --finish-only`: the body-alone controller against the video from the
   first frame (report.json, overlay_strip.png, video.mp4).

The figures (fall, NR against the helped rollout, joint error and reprojection) are printed as one JSON
line and written to DIR/body_alone.json, beside the helped controller's.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

POSE_FIELDS = ("root_pos", "root_rot", "joint_rot")


def helped_reference(run: Path, out: Path) -> Path:
    """DIR/motion.npz: RUN's reconstruction with the helped rollout's poses. The rollout has one frame per
    control step (30 Hz); a video at another rate gives its per-frame fields (keypoints, contacts) at the
    reconstruction frame nearest each control step."""
    from learner.atomic_io import atomic_output
    from learner.errors import SfvError

    motion = dict(np.load(run / "motion.npz", allow_pickle=True))
    simulated = np.load(run / "simulated.npz", allow_pickle=True)
    times, steps = np.asarray(motion["frame_times"], float), np.asarray(simulated["frame_times"], float)
    if "fell_at_s" in simulated.files and np.isfinite(float(simulated["fell_at_s"])):
        raise SfvError(f"{run}: the helped rollout fell at {float(simulated['fell_at_s']):.2f} s: no motion to follow")
    nearest = np.abs(times[None, :] - steps[:, None]).argmin(axis=1)
    frames = len(times)
    for name, value in motion.items():
        if np.ndim(value) >= 1 and len(value) == frames:
            motion[name] = np.asarray(value)[nearest]
    motion.update({name: simulated[name] for name in (*POSE_FIELDS, "frame_times")})
    motion["fps"] = np.asarray(1.0 / float(np.median(np.diff(steps))))
    out.mkdir(parents=True, exist_ok=True)
    path = out / "motion.npz"
    with atomic_output(path) as temporary:
        with open(temporary, "wb") as handle:
            np.savez(handle, **motion)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path, help="an `sfv pipeline` output directory (motion.npz, simulated.npz, report.json)")
    parser.add_argument("--out", type=Path, required=True, help="the second stage's directory")
    parser.add_argument("--samples", type=int, default=None, help="training samples (default: the pipeline's)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    from learner.atomic_io import atomic_write_json
    from services.commands._pipeline_settings import STATIC_DEFAULTS

    helped = json.loads((args.run / "report.json").read_text())
    motion = helped_reference(args.run, args.out)
    samples = args.samples or STATIC_DEFAULTS["samples"]
    python = sys.executable
    subprocess.run([python, "-m", "services.cli", "train", "--motion", str(motion), "--out", str(args.out / "train"),
                    "--samples", str(samples), "--first-frame-share", str(STATIC_DEFAULTS["first_frame_share"]),
                    "--env.residual-force", "0", "--seed", str(args.seed), "--quiet"], check=True, cwd=REPO)
    subprocess.run([python, "-m", "services.cli", "pipeline", helped["video"], "--out", str(args.out), "--finish-only",
                    "--quiet"], check=True, cwd=REPO)
    alone = json.loads((args.out / "report.json").read_text())
    keys = ("outcome", "fell", "fell_at_s", "normalized_return", "joint_position_error_m", "reprojection_error_px",
            "foot_skating_m_s")
    result = {"run": str(args.run), "samples": samples, "seed": args.seed,
              "helped": {**{k: helped.get(k) for k in keys}, "help": helped.get("residual_force_body_weight"),
                         "without_help": helped.get("without_residual_force")},
              "body_alone": {k: alone.get(k) for k in keys}}
    atomic_write_json(args.out / "body_alone.json", result)
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
