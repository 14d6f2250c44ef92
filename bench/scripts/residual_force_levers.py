"""Issue 44: the residual root wrench's levers on one video, side by side.

For each `sfv pipeline` run directory given (the same video, trained with different
`--env.residual-force` / `--env.residual-force-weight`), the run's settings, report.json's
figures (outcome, NR, tracking error, the help used, the same episode with the help at zero,
foot skating, penetration) and the errors against the Pose2Sim markers of the person followed
(`services.bench.videos_truth.truth_errors`: PA-MPJPE, MPJPE after one similarity, acceleration
error; 30 Hz grid). One JSON, written atomically.

    .venv/bin/python -m bench.scripts.residual_force_levers VIDEO RUN [RUN ...] --out bench/results/residual_force_levers.json
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from learner.atomic_io import atomic_write_json  # noqa: E402

REPORT_KEYS = ("outcome", "normalized_return", "root_relative_joint_error_m", "residual_force_body_weight",
               "without_residual_force", "foot_skating_m_s", "ground_penetration_m")


def run_row(video: Path, run: Path) -> dict:
    from actors.motion.formats.io import load_motion
    from services.bench.videos_truth import truth_errors

    report = json.loads((run / "report.json").read_text())
    env = json.loads((run / "train" / "config.json").read_text())["env"]
    truth = truth_errors(video, report, load_motion(str(run / "motion.npz")), load_motion(str(run / "simulated.npz")))
    return {"run": str(run), "residual_force": env.get("residual_force", 0.0),
            "residual_force_weight": env.get("residual_force_weight"), **{k: report.get(k) for k in REPORT_KEYS},
            "ground_truth": truth}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("video", type=Path)
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    rows = [run_row(args.video, run) for run in args.runs]
    atomic_write_json(args.out, {"video": str(args.video), "rows": rows})
    for row in rows:
        gt = row["ground_truth"]["simulated"]
        print(f"residual force {row['residual_force']} weight {row['residual_force_weight']}: PA-MPJPE {gt['pa_mpjpe_mm']} mm, "
              f"help {row['residual_force_body_weight']}, alone {row['without_residual_force']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
