"""Can the body alone follow what the helped body did? Issue 44: a second stage after `sfv pipeline`
(now the pipeline's own stage, `services/pipeline/body_alone.py`; this script runs it into a separate DIR).

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

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path, help="an `sfv pipeline` output directory (motion.npz, simulated.npz, report.json)")
    parser.add_argument("--out", type=Path, required=True, help="the second stage's directory")
    parser.add_argument("--samples", type=int, default=None, help="training samples (default: the pipeline's)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    from learner.atomic_io import atomic_write_json
    from services.commands._pipeline_settings import STATIC_DEFAULTS

    from services.pipeline.body_alone import helped_reference

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
