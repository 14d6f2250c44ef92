"""Flags shared by the commands that roll a trained policy out (render, export)."""
from __future__ import annotations


def add_rollout_args(p) -> None:
    p.add_argument("--episodes", type=int, default=1, help="episodes to roll out, one after another")
    p.add_argument("--seconds", type=float, default=None, help="cap on each episode's length in seconds")
    p.add_argument("--init", choices=("fsi", "rsi"), default="fsi", help="start at the clip's first frame or a random one")
    p.add_argument("--phase", type=float, default=None, metavar="P",
                   help="start every episode at phase P (0-1) of the clip instead (e.g. one of `sfv eval`'s fall_starts)")
    p.add_argument("--seed", type=int, default=0, help="episode k uses seed + k (pushes too)")
