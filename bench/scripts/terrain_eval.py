"""Issue 49: a terrain run evaluated on ground it never saw, at several difficulties.

For each run directory: `sfv eval RUN --terrain KIND --terrain-difficulty D --terrain-seed 1000
--episodes 32` (strict falls, evenly spaced start phases; seed 1000 was never drawn in training)
at every D given, for the best and the latest checkpoint, plus the training curve (samples, the
curriculum's mean difficulty, training NR and falls) and the in-training evaluations at
difficulty 1. One JSON, rewritten atomically.

    .venv/bin/python -m bench.scripts.terrain_eval runs/walk_mixed_5m --out bench/results/terrain_walk_5m.json
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from learner.atomic_io import atomic_write_json  # noqa: E402

FIGURES = ("normalized_return", "fall_rate", "episode_seconds", "distance_ratio", "joint_rotation_error_rad")
CURVE = ("samples", "charts/terrain_difficulty", "normalized_return", "fall_rate", "episode_length")


def evaluate(run: Path, kind: str, difficulty: float, checkpoint: str, seed: int, episodes: int) -> dict:
    command = [str(REPO / ".venv" / "bin" / "sfv"), "eval", str(run), "--checkpoint", checkpoint, "--terrain", kind,
               "--terrain-difficulty", str(difficulty), "--terrain-seed", str(seed), "--episodes", str(episodes)]
    out = subprocess.run(command, capture_output=True, text=True, check=True).stdout
    result = json.loads([line for line in out.splitlines() if line.startswith("{")][-1])
    return {"difficulty": difficulty, "checkpoint": checkpoint, **{k: result[k] for k in FIGURES}}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--terrain", default="mixed")
    parser.add_argument("--difficulties", default="0,0.1,0.25,0.5,1")
    parser.add_argument("--terrain-seed", type=int, default=1000)
    parser.add_argument("--episodes", type=int, default=32)
    args = parser.parse_args()
    document = {"terrain": args.terrain, "terrain_seed": args.terrain_seed, "episodes": args.episodes, "runs": {}}
    for run in args.runs:
        rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines() if line.strip()]
        config = json.loads((run / "config.json").read_text())
        entry = {"samples": rows[-1]["samples"], "motion": config.get("motion"),
                 "curve": [{k: r.get(k) for k in CURVE} for r in rows[:: max(1, len(rows) // 50)]],
                 "in_training_eval": [{"samples": r["samples"], **{k: r[k] for k in r if k.startswith("eval/")}}
                                      for r in rows if "eval/normalized_return" in r],
                 "unseen": []}
        for checkpoint in ("best", "latest"):
            for d in (float(x) for x in args.difficulties.split(",")):
                entry["unseen"].append(evaluate(run, args.terrain, d, checkpoint, args.terrain_seed, args.episodes))
                print(run.name, entry["unseen"][-1], flush=True)
        document["runs"][run.name] = entry
        atomic_write_json(args.out, document)
    return 0


if __name__ == "__main__":
    sys.exit(main())
