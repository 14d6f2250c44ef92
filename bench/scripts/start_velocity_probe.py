"""Does a trained policy score differently when its start states' velocities lose their spikes?

`sfv eval`'s 32 strict episodes of a run's best policy, once per `--windows` value of
`EnvConfig.start_velocity_median_rows` (the rows whose median each start velocity is;
`actors/motion/start_velocity_filter.py`), everything else the run's. The poses and the reward
are the same in every row, so a start that scores low only with the clip's own velocities
(window 1) is a start the clip's velocity jitter spoils, not one the policy cannot do.
Per window: the normalised return, the falls, and the starts under half the median.

    python bench/scripts/start_velocity_probe.py RUN [--windows 1,3] [--episodes 32] [--out F.json]
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from learner.errors import SfvError  # noqa: E402
from services.training.evaluation import evaluate_policy, make_eval_env, weak_starts  # noqa: E402
from services.training.policy_source import load_policy_source  # noqa: E402
from services.training.run_dir import write_json_atomic  # noqa: E402


def probe(run: str, windows: list[int], episodes: int) -> list[dict]:
    from threadpoolctl import threadpool_limits

    source = load_policy_source(run, None, None, "best")
    out = []
    for window in windows:
        env = make_eval_env(source.reference(), dataclasses.replace(source.env_config, start_velocity_median_rows=window))
        with threadpool_limits(1, user_api="blas"):
            result = evaluate_policy(source.policy, env, episodes)
        low = [[round(phase, 3), round(nr, 3)] for phase, nr in weak_starts(result["start_returns"])[1]]
        out.append({"median_rows": window, "normalized_return": round(result["normalized_return"], 4),
                    "falls": round(result["fall_rate"] * episodes), "episodes": episodes,
                    "low_starts": low, "start_returns": result["start_returns"]})
        print(f"median over {window} rows: NR {result['normalized_return']:.3f}, falls {out[-1]['falls']} / {episodes}, "
              f"low starts {out[-1]['low_starts']}", flush=True)
    return out


def parse_windows(text: str) -> list[int]:
    try:
        windows = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise SfvError(f"--windows {text!r}: give odd row counts such as 1,3") from None
    if not windows or any(w < 1 or w % 2 == 0 for w in windows):
        raise SfvError(f"--windows {text!r}: give odd row counts >= 1 such as 1,3")
    return windows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run", help="a run directory (its best.pt and config.json)")
    p.add_argument("--windows", default="1,3", help="median windows (control rows) of start velocities to compare; 1: the clip's own")
    p.add_argument("--episodes", type=int, default=32, help="strict episodes per window, at evenly spaced phases")
    p.add_argument("--out", default=None, help="JSON file for the results")
    args = p.parse_args(argv)
    try:
        windows = parse_windows(args.windows)
        if args.episodes <= 0:
            raise SfvError(f"--episodes must be positive, got {args.episodes}")
        results = probe(args.run, windows, args.episodes)
    except SfvError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.out:
        write_json_atomic(Path(args.out), {"run": args.run, "episodes": args.episodes, "windows": results})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
