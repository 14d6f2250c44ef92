"""The box check of issue 15: a policy trained on a box scene, scored against the box it was trained for.

    python bench/scripts/box_scene_check.py RUN --out bench/results/scene_box_jump.json

RUN is a `sfv train` run on `bench/scenes/box_jump.npz` with `--scene` (see `bench/scripts/box_clip.py`;
bench/reports/moving_camera.md's "Boxes in the scene" section has the command). Writes one JSON object:

- `training`: the run's evaluation figures (eval NR by the env's reward, imitation plus 002's
  scene reward over their maximum; fall rate; episode length) at each evaluation;
- `scenes`: deterministic evaluations (`services.training.evaluation.evaluate_policy`,
  strict falls, 8 evenly spaced starts) with the boxes fixed at the true e, and at the four
  corners of the run's scene domain: a policy that uses e does best at the truth;
- the PNG learning curve of the run is copied beside the JSON.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

FIGURES = ("eval/normalized_return", "eval/fall_rate", "eval/episode_seconds")


def _training_curve(run: Path) -> list[dict]:
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines() if line.strip()]
    return [{"samples": r["samples"], **{k.split("/", 1)[1]: r[k] for k in FIGURES}} for r in rows if r.get("eval/normalized_return") is not None]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run")
    parser.add_argument("--out", required=True)
    parser.add_argument("--episodes", type=int, default=8)
    args = parser.parse_args(argv)
    from services.training.run_dir import write_json_atomic
    from services.training.evaluation import evaluate_policy
    from services.training.policy_source import load_policy_source

    run, out = Path(args.run), Path(args.out)
    source = load_policy_source(str(run), None, None)
    env = source.make_env()
    if env.scene is None:
        raise SystemExit(f"{run}: the run has no scene (train it with --scene)")
    truth = np.asarray(env.motion.extras["scene_truth"])[:, [0, 2]].reshape(-1)
    low, high = env.scene.bounds()
    candidates = {"truth": truth, **{f"corner_{i}": np.where([i & 1, i & 2], high, low) for i in range(4)}}
    scenes = {}
    for name, e in candidates.items():
        env.set_scene(e)
        figures = evaluate_policy(source.policy, env, args.episodes)
        scenes[name] = {"e": [round(float(v), 4) for v in e], **{k: figures[k] for k in ("normalized_return", "fall_rate", "episode_seconds")}}
    result = {"run": str(run), "motion": env.motion.name, "scene_file": env.config.scene, "scene_randomise": env.config.scene_randomise,
              "training": _training_curve(run), "scenes": scenes}
    write_json_atomic(out, result)
    if (run / "learning_curve.png").exists():
        shutil.copyfile(run / "learning_curve.png", out.with_suffix(".png"))
    print(json.dumps({"training_last": result["training"][-1] if result["training"] else None,
                      "scenes": {k: round(v["normalized_return"], 3) for k, v in scenes.items()}}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
