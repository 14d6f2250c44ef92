"""`sfv experts`: one resumable job that trains a tracking expert per clip (004 §3.2).

The job is a Ray job graph: one Ray task per training, each a whole `Trainer` run with the
in-process runner (its rollout workers and PPO learner in the task's process, one core,
`torch_threads` 1), so Ray runs K = cores trainings at once (`parallel`). Each clip is a
standard run directory `DIR/<clip>/` (the layout of `sfv train --out DIR/<clip>`), so a run
made by hand is adopted as it is: a clip whose newest valid checkpoint has reached the sample
budget is skipped, one with a checkpoint below it is resumed (`--resume`'s rules: its saved
settings, the budget raised), any other starts afresh. A killed job resumes the same way.

Mirrored clips (`<clip>_mirror`) are not trained: `MirroredExpert` serves them from their
original's expert, so asking for one trains its original. `all` is every DeepMimic
humanoid3d clip in pybullet_data and its mirror. A motion file (`sfv motion bend deepmimic:walk
--yaw-rate 30 ... --out walk_turn30.npz`) is a clip named by its stem: the locomotion variety a
task's module needs (turns, speeds) trains in the same job.

The body (`character`, `--character humanoid3d|g1`) is the template's `env.character`; each
run's config.json remembers it, so `sfv eval` / `render` of an expert build that body. A
humanoid clip trains on the G1 retargeted at load (`actors/motion/character_reference.py`). An
experts directory holds one body's experts: extending or resuming a directory of one with the
other is refused in one line naming `--character` and the directory. Mirrored experts come by
symmetry for both bodies (`mirrored_expert.py`; the G1's hinge mirror signs are read off its
model), so `all` is every clip and its mirror for the G1 too.

Robustness to action noise (004 §3.2: sigma = .1 per actuator on [-1, 1] actions) needs no
extra setting: PPO explores with a fixed Gaussian action std of 0.1 in the env's normalised
action units (`learner/config.py` `action_std`), which is that noise, throughout training.

Deviation: 004 trains each expert far longer (and with DeepMimic-style RL at scale); the
default budget here (1 M samples, curriculum over the first half) is what one clip costs in a
few minutes on this machine; the expert table (`table.py`) says how well each one tracks.
"""
from __future__ import annotations

import dataclasses
import json
import os
import time
from pathlib import Path

from actors.character.mirror import MIRROR_SUFFIX
from actors.motion.formats.io import DEEPMIMIC_CLIPS
from learner.errors import SfvError
from services.experts.library import MIRROR_CHARACTERS, check_mirror, directory_character
from services.training.config import TrainConfig
from services.training.run_dir import CONFIG_FILE, read_run_config

ALL = "all"
HUMANOID = "humanoid3d"  # the default body (`EnvConfig.character`)
DEFAULT_SAMPLES = 1_000_000
JOB_FILE = "experts_job.json"
POLL_S = 2.0


# ----------------------------------------------------------------------------- clip lists
MOTION_FILE_SUFFIXES = (".npz", ".json", ".bvh")


def is_motion_file(name: str) -> bool:
    return Path(name).suffix.lower() in MOTION_FILE_SUFFIXES


def clip_motion_files(names: list[str]) -> dict[str, str]:
    """{clip: path} for the names that are motion files (`sfv motion bend ... --out walk_turn30.npz`):
    such a clip is named by the file's stem and trains `--motion PATH` (its mirror, `<stem>_mirror`,
    is served by symmetry like any other)."""
    files: dict[str, str] = {}
    for name in names:
        path = Path(name)
        if is_motion_file(name):
            if not path.is_file():
                raise SfvError(f"sfv experts: {name}: no such motion file")
            stem = path.stem
            if stem in DEEPMIMIC_CLIPS or (stem in files and files[stem] != str(path.resolve())):
                raise SfvError(f"sfv experts: {name}: its clip name {stem!r} is taken (rename the file)")
            files[stem] = str(path.resolve())
    return files


def expand_clips(names: list[str], character: str = HUMANOID, known: tuple[str, ...] = ()) -> list[str]:
    """Clip names in order, duplicates dropped; `all` = every clip and its mirror (a body
    without hinge mirror signs, none registered now: every clip). A name is a DeepMimic clip,
    a motion file (its stem: `clip_motion_files`), one of `known` (the experts directory's own
    runs) or any of these with `_mirror`; anything else is an SfvError naming it, and so is a
    mirror for such a body."""
    mirrors = character in MIRROR_CHARACTERS
    files = clip_motion_files(names)
    allowed = set(DEEPMIMIC_CLIPS) | set(files) | set(known)
    clips: list[str] = []
    for name in names:
        every = [c for clip in DEEPMIMIC_CLIPS for c in ((clip, clip + MIRROR_SUFFIX) if mirrors else (clip,))]
        expanded = every if name == ALL else [Path(name).stem if is_motion_file(name) else name]
        for clip in expanded:
            if clip.removesuffix(MIRROR_SUFFIX) not in allowed:
                raise SfvError(f"sfv experts: {clip!r} is not a DeepMimic clip, a motion file or <clip>{MIRROR_SUFFIX} "
                               f"(known: {', '.join(DEEPMIMIC_CLIPS)}, or all)")
            check_mirror(clip, character)
            if clip not in clips:
                clips.append(clip)
    if not clips:
        raise SfvError("sfv experts: no clips given (name clips, or all)")
    return clips


def known_runs(out: Path) -> tuple[str, ...]:
    """The run directories already in an experts directory (clips trained from files included)."""
    return tuple(p.name for p in Path(out).iterdir() if (p / CONFIG_FILE).is_file()) if Path(out).is_dir() else ()


def clips_to_train(clips: list[str]) -> list[str]:
    """The originals the clip list needs trained (a mirror needs its original)."""
    trained: list[str] = []
    for clip in clips:
        original = clip.removesuffix(MIRROR_SUFFIX)
        if original not in trained:
            trained.append(original)
    return trained


# ------------------------------------------------------------------------- run status
def samples_done(run_dir: Path) -> int:
    """Samples of the newest valid checkpoint (0 when there is none); verifies it."""
    from learner.checkpoint import latest_checkpoint, load_checkpoint

    latest = latest_checkpoint(run_dir) if run_dir.is_dir() else None
    return int(load_checkpoint(latest)["samples"]) if latest is not None else 0


def samples_logged(run_dir: Path) -> int:
    """Samples of metrics.jsonl's last whole line (cheap: the file's tail only), for progress."""
    path = run_dir / "metrics.jsonl"
    try:
        with open(path, "rb") as f:
            f.seek(max(0, path.stat().st_size - 8192))
            lines = f.read().decode(errors="replace").splitlines()
    except OSError:
        return 0
    for line in reversed(lines):
        try:
            return int(json.loads(line)["samples"])
        except (ValueError, KeyError, TypeError):
            continue
    return 0


def check_character(out: Path, character: str) -> None:
    """An experts directory holds one body's experts: a trained run of another character in
    `out` is a one-line SfvError naming `--character` and the directory."""
    found = directory_character(out)
    if found is not None and found[0] != character:
        trained, run_dir = found
        raise SfvError(f"sfv experts: {out} holds {trained} experts ({run_dir.name}/), not {character}: "
                       f"rerun with --character {trained}, or give another --out for the {character}")


def expert_config(template: TrainConfig, clip: str, run_dir: Path, samples: int, curriculum_samples: int | None,
                  motion: str | None = None) -> tuple[TrainConfig, bool]:
    """(config, resume) of one clip's training: the run's saved config with the budget raised
    when it has a checkpoint (its character must be the template's), else the template for this
    clip; `motion` is what it trains (default `deepmimic:<clip>`; a file for a file's clip)."""
    motion = motion or f"deepmimic:{clip}"
    done = samples_done(run_dir)
    settings = dict(out=str(run_dir), samples=int(samples), runner=template.runner, workers=template.workers,
                    torch_threads=template.torch_threads, plot_every=template.plot_every)
    if done > 0:
        config = read_run_config(run_dir)
        if config.motion != motion:
            raise SfvError(f"{run_dir / CONFIG_FILE}: trains {config.motion}, not {motion}")
        if config.env.character != template.env.character:
            raise SfvError(f"sfv experts: {run_dir} is a {config.env.character} expert, not {template.env.character}: "
                           f"rerun with --character {config.env.character}, or give another --out")
        return dataclasses.replace(config, **settings), True
    curriculum = template.curriculum_samples if curriculum_samples is None else curriculum_samples
    config = dataclasses.replace(template, motion=motion, job_id=None, curriculum_samples=int(curriculum), **settings)
    return config, False


# --------------------------------------------------------------------------- the job
def train_one(config_dict: dict, resume: bool, progress: bool = False) -> dict:
    """The body of one Ray task: a whole training in this process (no progress bar in a
    task: the job's driver draws them from the run directories)."""
    import logging

    from services.training.driver import Trainer

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    config = TrainConfig.from_dict(config_dict)
    started = time.perf_counter()
    record = Trainer(config, resume=resume, progress=progress).run()
    return {"samples": int(record.get("samples", 0)), "seconds": time.perf_counter() - started,
            "samples_per_s": record.get("overall_samples_per_s"), "normalized_return": record.get("normalized_return")}


def default_parallel() -> int:
    """Trainings at once: one per core (each is one process: in-process workers, one torch thread)."""
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def job_template(samples: int = DEFAULT_SAMPLES, character: str = HUMANOID) -> TrainConfig:
    """The settings every new expert trains with: the project defaults (RSI-free ASI starts,
    residual exp-map actions, the episode curriculum over half the budget), workers in the
    task's process, one torch thread, on `character`'s body."""
    config = TrainConfig(samples=samples, curriculum_samples=max(1, samples // 2), runner="in_process", workers=2, torch_threads=1)
    return with_character(config, character)


def with_character(config: TrainConfig, character: str) -> TrainConfig:
    """`config` on `character`'s body (an SfvError naming the registered ones when there is no such body)."""
    from actors.character.characters import CHARACTER_NAMES

    if character not in CHARACTER_NAMES:
        raise SfvError(f"sfv experts: --character {character!r} is not a character (known: {', '.join(CHARACTER_NAMES)})")
    return dataclasses.replace(config, env=dataclasses.replace(config.env, character=character))


def run_experts_job(clips: list[str], out: str | Path, samples: int = DEFAULT_SAMPLES, parallel: int | None = None,
                    template: TrainConfig | None = None, curriculum_samples: int | None = None,
                    progress: bool = True, ray_address: str | None = None, character: str | None = None) -> dict:
    """Train every clip of `clips` (see `expand_clips`) that is not finished, K at once, on
    `character`'s body (default: the template's, humanoid3d); returns (and writes to
    DIR/experts_job.json) each clip's status. A directory of the other body's experts is refused."""
    from services.ray_session import ray_session

    template = template or job_template(samples)
    if character is not None:
        template = with_character(template, character)
    character = template.env.character
    out = Path(out)
    files = clip_motion_files(clips)
    clips = expand_clips(clips, character, known_runs(out))
    check_character(out, character)
    out.mkdir(parents=True, exist_ok=True)
    if curriculum_samples is None and template.curriculum_samples > samples:
        curriculum_samples = max(1, samples // 2)
    parallel = parallel or default_parallel()
    if parallel < 1:
        raise SfvError(f"sfv experts: --parallel must be positive, got {parallel}")
    status: dict[str, dict] = {}
    pending: list[tuple[str, TrainConfig, bool]] = []
    for clip in clips_to_train(clips):
        run_dir = out / clip
        motion = files.get(clip) or (read_run_config(run_dir).motion if clip not in DEEPMIMIC_CLIPS else None)
        config, resume = expert_config(template, clip, run_dir, samples, curriculum_samples, motion)
        config.validate()
        done = samples_done(run_dir) if resume else 0
        if done >= samples:
            status[clip] = {"state": "finished", "samples": done, "run": str(run_dir)}
        else:
            status[clip] = {"state": "resumed" if resume else "started", "from_samples": done, "run": str(run_dir)}
            pending.append((clip, config, resume))
    for clip in clips:
        if clip.endswith(MIRROR_SUFFIX):
            status[clip] = {"state": "mirrored", "of": clip.removesuffix(MIRROR_SUFFIX)}
    if pending and parallel == 1 and ray_address is None:
        _run_here(pending, status, progress)  # one at a time: no Ray needed (CI, debugging)
    elif pending:
        # The bars come from the run directories; the tasks' own output goes to the log (--verbose forwards it).
        with ray_session(ray_address, num_cpus=parallel, log_to_driver=None):
            _run_tasks(pending, status, samples, progress)
    summary = {"clips": clips, "samples": int(samples), "parallel": int(parallel), "character": character, "status": status}
    from learner.atomic_io import atomic_write_json

    atomic_write_json(out / JOB_FILE, summary, sort_keys=True)
    failed = [clip for clip, s in status.items() if s["state"] == "failed"]
    if failed:
        reasons = "; ".join(f"{clip}: {status[clip]['error']}" for clip in failed)
        raise SfvError(f"sfv experts: {len(failed)} training(s) failed ({reasons}); rerun the same command to resume them")
    return summary


def _run_here(pending: list, status: dict, progress: bool) -> None:
    """The trainings one after the other in this process, each with its own progress bar."""
    for clip, config, resume in pending:
        try:
            status[clip].update(state="trained", **train_one(config.to_dict(), resume, progress))
        except SfvError as exc:
            status[clip].update(state="failed", error=str(exc))


def _run_tasks(pending: list, status: dict, samples: int, progress: bool) -> None:
    """Submit one Ray task per training (Ray runs `num_cpus` of them at once) and draw a bar
    per clip plus an overall one from the run directories until all have ended."""
    import ray
    from tqdm import tqdm

    task = ray.remote(num_cpus=1, max_retries=0)(train_one)
    refs = {task.remote(config.to_dict(), resume): (clip, Path(config.out)) for clip, config, resume in pending}
    width = max(len(clip) for clip, _, _ in pending)
    overall = tqdm(total=len(pending), desc="experts".ljust(width), unit="clip", position=0, disable=not progress, dynamic_ncols=True)
    bars = {clip: tqdm(total=samples, desc=clip.ljust(width), unit="samples", position=i + 1, disable=not progress,
                       dynamic_ncols=True, initial=status[clip]["from_samples"]) for i, (clip, _, _) in enumerate(pending)}
    waiting = list(refs)
    try:
        while waiting:
            ready, waiting = ray.wait(waiting, num_returns=len(waiting), timeout=POLL_S)
            for ref in ready:
                clip, run_dir = refs[ref]
                try:
                    result = ray.get(ref)
                    status[clip].update(state="trained", **result)
                except ray.exceptions.RayError as exc:
                    cause = getattr(exc, "cause", None)
                    status[clip].update(state="failed", error=str(cause or exc).strip().splitlines()[-1][:300])
                overall.update(1)
            for clip, run_dir in refs.values():
                bar = bars[clip]
                bar.update(max(0, min(samples, samples_logged(run_dir)) - bar.n))
    finally:
        for bar in bars.values():
            bar.close()
        overall.close()
