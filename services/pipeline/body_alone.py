"""The static pipeline's second stage: the body alone, trained on the helped controller's rollout.

`sfv pipeline` trains its first controller with a residual root wrench (the help): a reconstruction
from video is not a motion the body alone can perform (docs/video.md, causes 1-20), and five of the
nine development videos' helped controllers fell once the help was taken away. The helped rollout
from the first frame (DIR/simulated.npz) is a motion the simulated body did perform, apart from the
help's push: no foot skating, no limbs shaking in depth. Made the reference of a second training with
the help at zero, the body alone completed all five of those videos from the first frame
(bench/results/body_alone_stage.json, one seed each; trained on the kinematic reference instead, the
park walk's body alone fell at 3.97 s). So when the helped controller needs its help, the pipeline
trains this stage (DIR/alone, twice the minutes):

    DIR/alone/motion.npz   the reconstruction (its camera, keypoints, contacts) with the helped
                           rollout's poses, one frame per control step (`helped_reference`)
    DIR/alone/train/       the second training, `--env.residual-force 0`, the pipeline's other settings
    DIR/alone/report.json, simulated.npz, video.mp4, overlay_strip.png: the body-alone controller
                           against the video from the first frame (`finish.py`)

DIR/report.json gains `body_alone` (whether the stage ran and why, and its figures) and `controller`
(one line: which controller the pipeline gives, and how it ends without help).

`--body-alone auto` (default) runs it when the helped controller completes the clip and falls (or
topples at the clip's end, `outcome.py`) without its help; `always` also when the body alone completes already; `off` never.

**It trains on while it falls.** The stage trains the pipeline's samples (`--samples`); where its
controller then falls from the first frame (or topples at the clip's end), it goes on from its checkpoint by half as many again and
plays it again, up to `--body-alone-max-samples` (default the larger of twice `--samples` and
SAMPLES_PER_CLIP_SECOND per second of clip; `further_samples`). Measured
on the park walk (bench/results/body_alone_seeds.json): seed 1 of the stage fell at 4.13 s of 4.40 at
2 M samples (drift, 1.28 m behind the reference) and completed at 3 M (NR .918, joint error 0.087 m,
reprojection 23.4 px; seed 0 at 2 M: .880, 0.24 m, 29.5 px). A stage that completes at once costs no more.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from learner.errors import SfvError

ALONE_DIR = "alone"
MODES = ("auto", "always", "off")
POSE_FIELDS = ("root_pos", "root_rot", "joint_rot")
# The body-alone report's figures kept in DIR/report.json's `body_alone`.
# A longer clip takes more samples to be followed whole, so the default cap grows with its length.
# Measured (bench/results/long_clip_budget.json): the 9.63-s walk that turns completes with the body
# alone at 6 M (0.62 M per second; fell at 3.90-5.83 s at 2-5 M), the park walk's second seed at
# 3 M for 4.40 s (0.68 M); 800 k leaves a quarter more. Every clip of the development set keeps 4 M.
SAMPLES_PER_CLIP_SECOND = 800_000
KEPT = ("outcome", "fell", "fell_at_s", "toppling", "normalized_return")


def completes(episode: dict) -> bool:
    """A first-frame episode (report.json, or its `without_residual_force`) that reaches the clip's end
    upright: no fall, and not toppling at the end (`outcome.py`; a report written before `toppling`
    existed says it in its outcome line)."""
    return not episode["fell"] and not toppling(episode)


def toppling(episode: dict) -> bool:
    flag = episode.get("toppling")
    return bool(flag) if flag is not None else "toppling at its end" in str(episode.get("outcome", ""))


def ending(episode: dict, upright: str = "completes the clip from its first frame") -> str:
    """How a first-frame episode ends, in words: "falls at T s", "reaches the clip's end, toppling", or `upright`."""
    if episode["fell"]:
        return f"falls at {episode['fell_at_s']:.2f} s"
    return "reaches the clip's end, toppling" if toppling(episode) else upright


def stage_decision(report: dict, mode: str) -> tuple[bool, str]:
    """(train the second stage?, one line saying why) from the helped controller's report."""
    if mode not in MODES:
        raise SfvError(f"--body-alone: {mode!r} is not one of {', '.join(MODES)}")
    unaided = report.get("without_residual_force")
    if mode == "off":
        return False, "the body-alone stage: off (--body-alone off)"
    if unaided is None:
        return False, "the body-alone stage: not needed (the controller was trained without a residual root force)"
    if report["fell"]:
        return False, (f"the body-alone stage: skipped (the helped controller fell at {report['fell_at_s']:.2f} s: "
                       "no rollout of the whole clip to follow)")
    if mode == "auto" and completes(unaided):
        return False, "the body-alone stage: not needed (the controller completes the clip without its help too)"
    cause = ("--body-alone always" if completes(unaided)
             else f"the helped controller {ending(unaided)} without its help")
    return True, f"the body-alone stage: training the body alone on the helped rollout ({cause}) into {ALONE_DIR}/"


def max_samples(first: int, given: int | None, flag: str = "--body-alone-max-samples", clip_seconds: float = 0.0) -> int:
    """A stage's sample cap: the value of `flag` (`--body-alone-max-samples`, `--helped-max-samples`), or
    twice its first budget, or SAMPLES_PER_CLIP_SECOND per second of a longer clip."""
    if given is None:
        return max(2 * first, int(round(SAMPLES_PER_CLIP_SECOND * clip_seconds, -5)))
    if given < first:
        raise SfvError(f"{flag}: {given} is below the stage's first budget (--samples {first})")
    return given


def further_samples(report: dict, trained: int, first: int, cap: int) -> int | None:
    """A stage's next sample budget after a rollout `report`: while its controller falls or topples at the
    clip's end (the body alone; the first controller with its help), `first` / 2 more, up to `cap`; None:
    it completes, or the cap is reached."""
    if completes(report) or trained >= cap:
        return None
    return min(cap, trained + max(1, first // 2))


def helped_reference(run: Path, out: Path) -> Path:
    """`out`/motion.npz: `run`'s reconstruction with its helped rollout's poses. The rollout has one frame
    per control step (30 Hz); a video at another rate gives its per-frame fields (keypoints, contacts) at
    the reconstruction frame nearest each control step. A rollout that fell is refused."""
    from learner.atomic_io import atomic_output

    run, out = Path(run), Path(out)
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


def stage_summary(ran: bool, line: str, alone: dict | None = None, samples: int | None = None) -> dict:
    """DIR/report.json's `body_alone`: whether the stage ran, why, the samples it trained, and the
    body-alone report's figures."""
    summary = {"ran": ran, "line": line}
    if alone is not None:
        if samples is not None:
            summary["samples"] = samples
        summary.update({key: alone.get(key) for key in KEPT}, directory=str(Path(alone["files"]["report"]).parent),
                       run=alone.get("run"),
                       joint_position_error_m=alone["joint_position_error_m"]["mean"],
                       reprojection_error_px=(alone["reprojection_error_px"]["simulated"] or {}).get("mean"))
    return summary


def final_episode(helped: dict, summary: dict) -> tuple[str, dict]:
    """(which controller, its first-frame episode with no help: fell, fell_at_s, normalized_return): the
    body-alone stage's where it ran, else the first controller's with its help at zero (or, trained
    without help, its own)."""
    if summary.get("ran"):
        return f"the body alone ({ALONE_DIR}/train, no help)", summary
    unaided = helped.get("without_residual_force")
    if unaided is None:
        return "train (no help)", helped
    return "train, with its help at zero", unaided


def controller_line(helped: dict, summary: dict) -> str:
    """Which controller the pipeline gives and how it ends without help, in one line."""
    which, episode = final_episode(helped, summary)
    return f"controller: {which}: {ending(episode)}, NR {episode['normalized_return']:.3f}"


def record_stage(report_path: Path, summary: dict) -> dict:
    """DIR/report.json with `body_alone` and `controller` written in (atomically); returns it."""
    import json

    from learner.atomic_io import atomic_write_json

    report = json.loads(Path(report_path).read_text())
    report["body_alone"] = summary
    report["controller"] = controller_line(report, summary)
    atomic_write_json(report_path, report)
    return report
