"""Issue 48 part 4 (a): the root-path estimate alone, on synthetic moving-camera data.

A camera that tracks the character leaves the reconstruction a root-relative pose and foot
contacts, nothing of the path. Here DeepMimic clips stand in for that reconstruction: each is
sampled at 30 fps (a video's rate) for 10 s (looped with its cycle offset; a clip that does not
loop once), its contacts come from foot height and speed (`clip_cues.clip_contacts`'s rule: a
sole within LABEL_HEIGHT_M = 5 cm of the floor and slower than 1.5 m/s; clip_cues's own 3 cm is
scored too, as labels_3cm: the DeepMimic jump's feet hover 3-5 cm above the floor while they
push off, so at 3 cm its labels end 0.2 s before take-off), its pose is the clip's with the
root path thrown away, and
`services/reconstruction/root_path.py` estimates the path back. Conditions: clean; contacts
with 10 % of the frames flipped per foot; 2.5 cm RMS 3D noise on the root and on each foot
(independent per frame); both. Noisy conditions average SEEDS seeds. Metrics, as WHAM / GVHMR
report them:

- rte_pct: root translation error, GVHMR's definition: the estimate rigidly aligned to the truth
  (rotation and translation, no scale), the mean 3D root distance over the frames divided by
  the length of the true path, in %; rte_start_pct: aligned at the start only (the estimate
  starts at the true first root, no rotation); end_error_pct: the last frame's distance so;
- heading_error_deg: mean absolute angle between the estimated and the true horizontal
  displacement over 1 s windows (start-aligned; windows where the truth moves under 0.1 m skipped);
- foot_sliding_mm: GVHMR's: sole corners that the truth holds still (under 1 cm per frame),
  their mean displacement per frame (30 fps) in the estimated world, mm; foot_sliding_true_root_mm
  the same with the true root (what the pose noise alone slides);
- flight_height_rmse_m: root height error over frames with no foot down between two with one
  (the arcs; a clip that ends in the air is held at its take-off there, with confidence 0);
- held_*: the same for the root-free motion as written before (the root held at its start).
Plus ablations of the estimator's choices on the walk and the run, and a plot of the estimated
against the true path for the walk and the run.

    python bench/scripts/root_path_estimate.py   # -> bench/results/root_path_estimate.{json,png}
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

RESULT = REPO / "bench" / "results" / "root_path_estimate.json"
PLOT = RESULT.with_suffix(".png")
CLIPS = ("walk", "run", "jump", "dance_a", "dance_b", "spin", "cartwheel", "kick")
FPS, SECONDS, SEEDS = 30.0, 10.0, 3
FLIP_FRACTION, NOISE_RMS_M = 0.10, 0.025
STATIC_M = 0.01  # GVHMR's foot-static threshold per frame
LABEL_HEIGHT_M = 0.05


def contact_labels(root: np.ndarray, points: np.ndarray, times: np.ndarray, height: float) -> np.ndarray:
    """(T, 2) feet down: `clip_cues.clip_contacts`'s rule with the sole height bound `height`."""
    from actors.envs.modes.movingcam.clip_cues import CONTACT_SPEED_MPS

    world = root[:, None, None] + points  # (T, 2, 8, 3)
    feet = world.mean(axis=2)[..., :2]
    speed = np.linalg.norm(np.gradient(feet, times, axis=0), axis=-1)
    return ((world[..., 2].min(axis=2) < height) & (speed < CONTACT_SPEED_MPS)).astype(np.float64)


def synthetic(clip: str, height: float = LABEL_HEIGHT_M) -> dict:
    """The clip at 30 fps: times, truth root, root-relative sole corners, contact labels."""
    from actors.motion.formats.io import load_motion
    from services.reconstruction.root_path import sole_points

    motion = load_motion(f"deepmimic:{clip}")
    duration = SECONDS if motion.loop else motion.duration
    times = np.arange(0.0, duration + 1e-9, 1.0 / FPS)
    pose = motion.sample(times)
    points = sole_points(pose.root_rot, pose.joint_rot)
    return {"times": times, "root": pose.root_pos, "points": points,
            "contacts": contact_labels(pose.root_pos, points, times, height)}


def corrupt(data: dict, flip: bool, noise: bool, rng) -> tuple[np.ndarray, np.ndarray]:
    contacts, points = data["contacts"].copy(), data["points"].copy()
    if flip:
        mask = rng.random(contacts.shape) < FLIP_FRACTION
        contacts[mask] = 1.0 - contacts[mask]
    if noise:
        sigma = NOISE_RMS_M / math.sqrt(3.0)
        feet = rng.normal(0.0, sigma, points.shape[:2] + (1, 3))  # each foot moves rigidly
        root = rng.normal(0.0, sigma, points.shape[:1] + (1, 1, 3))
        points = points + feet - root
    return points, contacts


# ------------------------------------------------------------------------------ metrics
def rigid_align(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """`estimate` rotated and translated (no scale) onto `truth` in the least-squares sense."""
    mu_e, mu_t = estimate.mean(axis=0), truth.mean(axis=0)
    u, _, vt = np.linalg.svd((estimate - mu_e).T @ (truth - mu_t))
    d = np.sign(np.linalg.det(u @ vt))
    rotation = u @ np.diag([1.0, 1.0, d]) @ vt
    return (estimate - mu_e) @ rotation + mu_t


def heading_error_deg(estimate: np.ndarray, truth: np.ndarray, window: int) -> float:
    de, dt = estimate[window:, :2] - estimate[:-window, :2], truth[window:, :2] - truth[:-window, :2]
    moving = np.linalg.norm(dt, axis=1) > 0.1
    if not moving.any():
        return float("nan")
    angle = np.arctan2(de[:, 1], de[:, 0]) - np.arctan2(dt[:, 1], dt[:, 0])
    return float(np.degrees(np.abs(np.angle(np.exp(1j * angle[moving])))).mean())


def foot_sliding_mm(estimate: np.ndarray, truth: np.ndarray, points: np.ndarray, clean: np.ndarray) -> float:
    true_feet = truth[:, None, None] + clean
    static = np.linalg.norm(np.diff(true_feet, axis=0), axis=-1) < STATIC_M
    moved = np.linalg.norm(np.diff(estimate[:, None, None] + points, axis=0), axis=-1)
    return float(1000.0 * moved[static].mean())


def rte_start_pct(estimate: np.ndarray, truth: np.ndarray) -> float:
    length = float(np.linalg.norm(np.diff(truth, axis=0), axis=1).sum())
    return 100.0 * float(np.linalg.norm(estimate - estimate[0] + truth[0] - truth, axis=1).mean()) / length


def metrics(estimate: np.ndarray, data: dict, points: np.ndarray) -> dict:
    truth = data["root"]
    length = float(np.linalg.norm(np.diff(truth, axis=0), axis=1).sum())
    start = estimate - estimate[0] + truth[0]
    down = (data["contacts"] > 0.5).any(axis=1)
    flight = ~down & (np.cumsum(down) > 0) & (np.cumsum(down[::-1])[::-1] > 0)  # gaps with a landing
    return {
        "rte_pct": 100.0 * float(np.linalg.norm(rigid_align(estimate, truth) - truth, axis=1).mean()) / length,
        "rte_start_pct": rte_start_pct(estimate, truth),
        "end_error_pct": 100.0 * float(np.linalg.norm(start[-1] - truth[-1])) / length,
        "heading_error_deg": heading_error_deg(start, truth, int(FPS)),
        "foot_sliding_mm": foot_sliding_mm(estimate, truth, points, data["points"]),
        "flight_height_rmse_m": float(np.sqrt(np.mean((estimate[flight, 2] - truth[flight, 2]) ** 2))) if flight.any() else None,
    }


def run_estimate(data: dict, points: np.ndarray, contacts: np.ndarray):
    from services.reconstruction.root_path import estimate_root_path

    return estimate_root_path(points, contacts, data["times"], data["root"][0, :2])


def condition(data: dict, flip: bool, noise: bool) -> dict:
    seeds = range(SEEDS) if (flip or noise) else range(1)
    rows = []
    for seed in seeds:
        points, contacts = corrupt(data, flip, noise, np.random.default_rng(seed))
        path = run_estimate(data, points, contacts)
        row = metrics(path.position, data, points)
        row["mean_confidence"] = float(path.confidence.mean())
        row["foot_sliding_true_root_mm"] = foot_sliding_mm(data["root"], data["root"], points, data["points"])
        rows.append(row)
    return {k: (None if rows[0][k] is None else round(float(np.mean([r[k] for r in rows])), 4)) for k in rows[0]}


def held(data: dict) -> dict:
    """The root-free file as written before: horizontal root at its start, true height."""
    estimate = data["root"].copy()
    estimate[:, :2] = estimate[0, :2]
    return {k: (None if v is None else round(v, 4)) for k, v in metrics(estimate, data, data["points"]).items()}


def clip_summary(clip: str) -> tuple[dict, dict]:
    data = synthetic(clip)
    flight = ~(data["contacts"] > 0.5).any(axis=1)
    gaps = [(e - s) / FPS for s, e in _runs(flight)]
    summary = {
        "frames": len(data["times"]), "seconds": round(float(data["times"][-1]), 3),
        "path_length_m": round(float(np.linalg.norm(np.diff(data["root"], axis=0), axis=1).sum()), 3),
        "frames_no_foot_down": int(flight.sum()), "longest_gap_s": round(max(gaps, default=0.0), 3),
        "clean": condition(data, False, False), "contacts_flipped_10pct": condition(data, True, False),
        "pose_noise_2p5cm": condition(data, False, True), "both": condition(data, True, True),
        "held_root_free": held(data),
    }
    at_3cm = synthetic(clip, 0.03)
    summary["labels_3cm"] = {"clean": condition(at_3cm, False, False), "both": condition(at_3cm, True, True)}
    return summary, data


def _runs(mask: np.ndarray):
    from services.reconstruction.root_path import _runs as runs

    return runs(mask)


# ----------------------------------------------------------------------------- ablations
def ablations(data: dict) -> dict:
    """What each choice of the estimator buys (start-aligned RTE %, clean and both noises)."""
    import services.reconstruction.root_path as rp

    def score(**overrides) -> dict:
        saved = {k: getattr(rp, k) for k in overrides if k != "points"}
        try:
            for k, v in overrides.items():
                if k != "points":
                    setattr(rp, k, v)
            out = {}
            for name, flip, noise in (("clean", False, False), ("flip10", True, False), ("both", True, True)):
                values = []
                for seed in range(SEEDS if (flip or noise) else 1):
                    points, contacts = corrupt({**data, "points": overrides.get("points", data["points"])}, flip, noise,
                                               np.random.default_rng(seed))
                    path = run_estimate(data, points, contacts)
                    values.append(rte_start_pct(path.position, data["root"]))
                out[name] = round(float(np.mean(values)), 3)
            return out
        finally:
            for k, v in saved.items():
                setattr(rp, k, v)

    ankle = data["points"].mean(axis=2, keepdims=True)  # the foot box's centre: the anchor without rolling
    return {
        "default": score(),
        "anchor_foot_centre": score(points=ankle),
        "no_median_filter": score(MEDIAN_FRAMES=1),
        "median_filter_5": score(MEDIAN_FRAMES=5),
        "no_disagreement_rule": score(DISAGREE_MPS=1e9),
    }


# ---------------------------------------------------------------------------------- plot
def _plot_heights(ax, data: dict) -> None:
    """The jump's root height: the ballistic arcs across the frames with no foot down."""
    shown = data["times"] <= 3.6
    t, truth = data["times"][shown], data["root"][shown, 2]
    estimate = run_estimate(data, data["points"], data["contacts"])
    flight = ~(data["contacts"][shown] > 0.5).any(axis=1)
    ax.plot(t, truth, "k-", lw=2.5, label="truth (mocap root height)")
    ax.plot(t, estimate.position[shown, 2], "C0-", lw=1.5, label="estimate (feet on the floor; arcs where no foot is down)")
    ax.fill_between(t, 0.5, 1.3, where=flight, color="C1", alpha=0.15, label="no foot down")
    ax.plot(t, estimate.confidence[shown] * 0.5 + 0.5, "C2:", lw=1.2, label="confidence (0.5 + 0.5 c)")
    ax.set_ylim(0.5, 1.3)
    ax.set_title("deepmimic:jump: root height")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("z (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")


def plot(datasets: dict, jump: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from learner.atomic_io import atomic_output

    fig, axes = plt.subplots(len(datasets) + 1, 1, figsize=(9, 3.2 * (len(datasets) + 1)))
    for ax, (clip, data) in zip(axes, datasets.items()):
        truth = data["root"]
        ax.plot(truth[:, 0], truth[:, 1], "k-", lw=2.5, label="truth (mocap root)")
        clean = run_estimate(data, data["points"], data["contacts"]).position
        ax.plot(clean[:, 0], clean[:, 1], "C0-", lw=1.5, label="estimate, true contacts and pose")
        points, contacts = corrupt(data, True, True, np.random.default_rng(0))
        noisy = run_estimate(data, points, contacts)
        ax.plot(noisy.position[:, 0], noisy.position[:, 1], "C3--", lw=1.2,
                label="estimate, 10% contacts flipped + 2.5 cm pose noise")
        ax.plot([truth[0, 0]], [truth[0, 1]], "ko")
        ax.set_title(f"deepmimic:{clip}, {data['times'][-1]:.0f} s at {FPS:.0f} fps: root path seen from above")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    _plot_heights(axes[-1], jump)
    fig.tight_layout()
    with atomic_output(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def main() -> None:
    from learner.atomic_io import atomic_write_json

    started = time.time()
    clips, datasets = {}, {}
    for clip in CLIPS:
        clips[clip], datasets[clip] = clip_summary(clip)
        print(clip, {k: clips[clip][k]["rte_pct"] for k in ("clean", "contacts_flipped_10pct", "pose_noise_2p5cm", "both")},
              flush=True)
    result = {
        "what": ("issue 48 part 4 (a): the contact-anchored root-path estimate alone on DeepMimic clips "
                 "(services/reconstruction/root_path.py)"),
        "fps": FPS, "seconds": SECONDS, "seeds": SEEDS, "flip_fraction": FLIP_FRACTION, "pose_noise_rms_m": NOISE_RMS_M,
        "clips": clips,
        "ablations_rte_start_pct": {clip: ablations(datasets[clip]) for clip in ("walk", "run")},
        "seconds_taken": round(time.time() - started, 1),
    }
    atomic_write_json(RESULT, result)
    plot({clip: datasets[clip] for clip in ("walk", "run")}, datasets["jump"], PLOT)
    print(f"-> {RESULT.relative_to(REPO)}, {PLOT.relative_to(REPO)}")


if __name__ == "__main__":
    main()
