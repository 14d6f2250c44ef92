"""Where a go-to policy succeeds: success against the target's position relative to the walker
(004 Fig. 6B's start-position heatmap; `sfv task heatmap RUN --out heatmap.png`).

The target of each episode is placed on a G x G grid (default 9 x 9, +-4 m, 1 m cells) in the
walker's heading frame at its start: x ahead, y to its left; the cell at the walker itself is
left out. `episodes_per_cell` episodes per cell start from different clip frames (the task's
own starts). The requested speed is the middle of `speed_range` and the requested heading the
direction to the target, so a cell measures where, not how fast. Success is the task's: the
target within `success_radius` before the horizon, deterministic policy. `policy` may be any
object with `mean(obs)`, the z = 0 chance line included.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from learner.atomic_io import atomic_write_json
from learner.errors import SfvError


def grid_offsets(grid: int, extent: float) -> np.ndarray:
    """(grid * grid, 2) heading-frame offsets, row-major from far ahead (+x) to behind, left (+y) to right."""
    xs = np.linspace(extent, -extent, grid)
    ys = np.linspace(extent, -extent, grid)
    return np.array([(x, y) for x in xs for y in ys])


def place_targets(env, offsets: np.ndarray) -> np.ndarray:
    """Put env i's first target at offsets[i % len(offsets)] in its heading frame; the observations after."""
    task = env.task
    root_xy, _, yaw = env.planar_state()
    for i in range(env.num_envs):
        dx, dy = offsets[i % len(offsets)]
        c, s = np.cos(yaw[i]), np.sin(yaw[i])
        world = np.array([c * dx - s * dy, s * dx + c * dy])
        task.place(i, root_xy[i] + world, float(np.mean(env.config.speed_range)), float(np.arctan2(world[1], world[0])))
    return env.refresh_observations()


def success_heatmap(env_config, policy, grid: int = 9, extent: float = 4.0, episodes_per_cell: int = 2, seed: int = 0) -> dict:
    from threadpoolctl import threadpool_limits

    from actors.envs.tasks.vector_task_env import VectorTaskEnv
    from services.tasks.evaluation import run_episodes

    if env_config.task != "go_to":
        raise SfvError(f"sfv task heatmap: the heatmap places go-to targets; this run's task is {env_config.task}")
    if grid < 2 or episodes_per_cell < 1 or not extent > 0:
        raise SfvError("sfv task heatmap: --grid >= 2, --episodes >= 1 per cell and a positive extent")
    offsets = grid_offsets(grid, extent)
    keep = np.linalg.norm(offsets, axis=1) > 1e-9  # not the walker's own cell
    cells = offsets[keep]
    env = VectorTaskEnv(env_config, len(cells) * episodes_per_cell, seed=seed)
    with threadpool_limits(1, user_api="blas"):
        per_episode, _ = run_episodes(env, policy, after_reset=lambda e: place_targets(e, cells))
    success = per_episode["successes"].astype(float).reshape(episodes_per_cell, len(cells)).mean(axis=0)
    fell = per_episode["fell"].astype(float).reshape(episodes_per_cell, len(cells)).mean(axis=0)
    rates = np.full(len(offsets), np.nan)
    rates[keep] = success
    falls = np.full(len(offsets), np.nan)
    falls[keep] = fell
    return {"grid": grid, "extent_m": extent, "episodes_per_cell": episodes_per_cell,
            "ahead_m": np.linspace(extent, -extent, grid).tolist(), "left_m": np.linspace(extent, -extent, grid).tolist(),
            "success": rates.reshape(grid, grid).tolist(), "fall_rate": falls.reshape(grid, grid).tolist(),
            "success_mean": float(np.nanmean(rates)), "fall_rate_mean": float(np.nanmean(falls))}


def plot_heatmap(record: dict, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    e = record["extent_m"]
    rates = np.array(record["success"], float)
    fig, ax = plt.subplots(figsize=(5, 4.6))
    image = ax.imshow(rates, vmin=0, vmax=1, cmap="viridis", extent=(e + 0.5, -e - 0.5, -e - 0.5, e + 0.5))
    ax.plot(0, 0, marker="^", color="white", markersize=10)  # the walker, facing up the page
    ax.set(xlabel="target to the walker's left (m)", ylabel="target ahead of the walker (m)",
           title=f"{title}\nsuccess {record['success_mean']:.2f}, falls {record['fall_rate_mean']:.2f}")
    fig.colorbar(image, ax=ax, label="success rate")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_heatmap(record: dict, out: Path, title: str) -> None:
    """`out` (.png) and its figures beside it (.json)."""
    atomic_write_json(Path(out).with_suffix(".json"), record, sort_keys=False)
    plot_heatmap(record, Path(out), title)
