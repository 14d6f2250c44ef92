"""Suite `learning`: how well and how fast PPO learns each skill, per initial-state strategy.

    sfv bench --suite learning --out-dir bench/learning [--skills deepmimic:walk,deepmimic:run]
              [--inits asi,rsi,fsi] [--seeds 0,1] [--samples 2M] [--workers 2] [--envs-per-worker 32]
              [--serial | --runner processes] [--eval-every 200k] [--eval-episodes 8] [--batch-size 4096] [--minibatch-size 256] [--final-episodes 32]

A grid of skills x inits x seeds at one sample budget, or a budget per skill (`--skills
backflip@20M,walk@1M`: a skill's `@BUDGET` overrides `--samples` for its runs). Every cell is one ordinary training
run (`services.training.driver.Trainer`, the code `sfv train` runs) into OUT_DIR/runs/<clip>_<init>_s<seed>/;
when it has finished, the run's newest checkpoint is evaluated with `services.training.evaluation.evaluate_run`
(deterministic policy, `--final-episodes` episodes) and its learning curve is read back from
metrics.jsonl (training normalised return per iteration, and the `eval/...` rows the trainer
writes every `--eval-every` samples). Everything goes into OUT_DIR/learning.json, rewritten
atomically after every run, and OUT_DIR/learning.png (one panel per skill, one line per
init and seed).

Resumable: a rerun of the same command skips the runs learning.json records as complete at
this budget (or more), continues a run that has checkpoints but no complete record from its
newest checkpoint (`Trainer(config, resume=True)`), and starts the rest afresh. A larger
`--samples` continues complete runs to the new budget. A run directory trained with other
settings (motion, init, seed, batch sizes, physics rate) is an error, not silently mixed.
A run trained by `sfv train` with the suite's settings (the defaults) can be moved into
OUT_DIR/runs/<clip>_<init>_s<seed>/ to be recorded without training again: the suite continues it
to the cell's budget and evaluates it, its training time read from its own metrics
(`services.bench.run_history`); a run whose settings differ from the cell's in anything but how it
was operated (runner, addresses, evaluation cadence) is refused, naming the settings.

learning.json (format "sfv-learning-1"):
    {"format", "command", "created", "updated", "machine", "threshold",
     "runs": {"<clip>_<init>_s<seed>": {
         "name", "skill", "init", "seed", "run_dir" (relative to OUT_DIR),
         "status": "complete" | "incomplete" (interrupted) | "failed" (an error; "error" holds it),
         "config": {motion, init, seed, samples (budget), workers, envs_per_worker, serial, device,
                    batch_size, minibatch_size, update_epochs, policy_lr, physics_hz, control_hz,
                    eval_every, eval_episodes, final_episodes},
         "samples", "wall_s" (training, all invocations; from the run's metrics when it came without a record), "eval_s", "samples_per_s" (samples / wall_s),
         "resumes" (times continued from a checkpoint), "finished", "machine",
         "eval": {every key evaluate_run returns: normalized_return, fall_rate, episode_length, ...},
         "curve": {"train": {"samples", "normalized_return", "fall_rate", "episode_length", "wall_s"},
                   "eval": {"samples", "wall_s", "eval/normalized_return", ... every eval/ key}}
                  (wall_s: training seconds up to the row, from the metrics' time stamps),
         "samples_to_threshold": first samples at which NR >= threshold, or null;
         "threshold_source": "eval" (eval rows + final eval) or "train_smoothed" (EMA 0.8 of the
                             training NR + final eval), used where the run has no eval rows}}}
"""
from __future__ import annotations

import dataclasses
import datetime
import gc
import json
import math
import re
import shlex
import shutil
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from learner.errors import SfvError
from services.bench.learning_report import INITS, THRESHOLD, _plot_safely, markdown_table, read_curve, result_line, samples_to_threshold
from services.training.config import RUNNER_NAMES as RUNNERS
from services.training.flags import whole_number

FORMAT = "sfv-learning-1"
RESULTS_FILE = "learning.json"
PLOT_FILE = "learning.png"
RUNS_DIR = "runs"
DEFAULT_SKILLS = ("deepmimic:walk", "deepmimic:run", "deepmimic:backflip", "deepmimic:cartwheel")
DEFAULT_SAMPLES = 2_000_000
EVAL_POINTS = 10  # default --eval-every: the budget / this, at most EVAL_EVERY_MAX
EVAL_EVERY_MAX = 500_000  # sfv train's cadence: best.pt is chosen among these evaluations
# Settings that make a run what it is; a run directory trained with others is not resumed into.
IDENTITY = {"motion": ("motion",), "init": ("init",), "seed": ("seed",), "batch_size": ("ppo", "batch_size"),
            "minibatch_size": ("ppo", "minibatch_size"), "physics_hz": ("env", "physics", "physics_hz")}
# Flags only the learning suite reads (argparse dest names); None when not given.
LEARNING_FLAGS = ("out_dir", "skills", "inits", "seeds", "samples", "workers", "serial", "runner", "eval_every", "eval_episodes",
                  "batch_size", "minibatch_size", "final_episodes", "device", "torch_threads")


@dataclass
class LearningConfig:
    out_dir: Path = field(default=Path("bench/learning"), metadata={"help": "learning.json, learning.png and runs/ go here"})
    skills: tuple[str, ...] = field(default=DEFAULT_SKILLS, metadata={"help": "motions to learn (names or files)"})
    inits: tuple[str, ...] = field(default=INITS, metadata={"help": "initial-state strategies"})
    seeds: tuple[int, ...] = field(default=(0,), metadata={"help": "base seeds of the runs"})
    samples: int = field(default=DEFAULT_SAMPLES, metadata={"help": "sample budget of every run"})
    workers: int = field(default=2, metadata={"help": "rollout workers per run"})
    envs_per_worker: int = field(default=32, metadata={"help": "envs per worker"})
    runner: str = field(default="ray", metadata={"help": "how the workers run: ray, in_process (--serial) or processes (one OS process each, no Ray: 3,900 against Ray's 2,650 samples/s for two trainings sharing 2 cores)"})
    device: str = field(default="cpu", metadata={"help": "torch device of the learner"})
    torch_threads: int = field(default=0, metadata={"help": "learner's torch threads (0: every core; 1 when two grids share a 2-core machine)"})
    batch_size: int | None = field(default=None, metadata={"help": "samples per PPO iteration (None: TrainConfig's, 4096)"})
    minibatch_size: int | None = field(default=None, metadata={"help": "samples per gradient step (None: TrainConfig's, 256, at most the batch)"})
    eval_every: int | None = field(default=None, metadata={"help": "samples between evaluations during training (None: budget / 10; 0: never)"})
    eval_episodes: int | None = field(default=None, metadata={"help": "episodes per evaluation during training (None: TrainConfig's, 8)"})
    final_episodes: int = field(default=32, metadata={"help": "episodes of the evaluation after training"})
    physics_hz: float | None = field(default=None, metadata={"help": "physics rate (None: the env's default)"})
    threshold: float = field(default=THRESHOLD, metadata={"help": "normalised return whose first crossing is reported"})
    progress: bool = field(default=False, metadata={"help": "the trainer's progress bar on stderr"})

    @property
    def serial(self) -> bool:
        """Workers in this process (`--serial`, the same as `--runner in_process`)."""
        return self.runner == "in_process"

    def resolved_eval_every(self, samples: int | None = None) -> int:
        """--eval-every, or the run's budget (`samples`, default --samples) / EVAL_POINTS, at most EVAL_EVERY_MAX."""
        budget = self.samples if samples is None else samples
        return min(EVAL_EVERY_MAX, max(1, budget // EVAL_POINTS)) if self.eval_every is None else self.eval_every


@dataclass(frozen=True)
class Cell:
    skill: str  # the motion as given to TrainConfig (deepmimic:walk or a path)
    clip: str  # short name for directories and labels
    init: str
    seed: int
    samples: int = DEFAULT_SAMPLES  # this run's budget: --samples, or the skill's @BUDGET

    @property
    def name(self) -> str:
        return f"{self.clip}_{self.init}_s{self.seed}"


# ------------------------------------------------------------------------- flags
def add_arguments(parser) -> None:
    """The learning suite's own flags (`sfv bench` also has --envs-per-worker, --physics-hz, --seed, --quiet)."""
    g = parser.add_argument_group("learning suite (--suite learning)")
    g.add_argument("--out-dir", default=None, help="directory of learning.json, learning.png and runs/ (required for --suite learning)")
    g.add_argument("--skills", default=None, help=f"comma-separated motions: deepmimic:<clip>, a bare clip name or a file or 'all' (every DeepMimic clip; default {','.join(DEFAULT_SKILLS)}) or 'specs' (every skill spec at its budget); NAME@BUDGET gives that skill its own sample budget (backflip@20M, cartwheel@spec)")
    g.add_argument("--inits", default=None, help="comma-separated initial-state strategies of asi, rsi, fsi (default all three)")
    g.add_argument("--seeds", default=None, help="comma-separated base seeds (default: --seed, 0)")
    g.add_argument("--samples", default=None, help=f"sample budget per run: 600, 500k, 2M, 1e6 (default {DEFAULT_SAMPLES:,})")
    g.add_argument("--workers", default=None, help="rollout workers per run (default 2)")
    g.add_argument("--serial", action="store_true", default=None, help="run the workers in this process, without Ray (machines without Ray); the same as --runner in_process")
    g.add_argument("--runner", default=None, choices=RUNNERS, help="how each run's workers run: ray (default), in_process, or processes (one OS process per worker, no Ray; the fastest on a small machine)")
    g.add_argument("--eval-every", default=None, help=f"samples between evaluations during training (default budget / {EVAL_POINTS}; 0: never)")
    g.add_argument("--eval-episodes", default=None, help="episodes per evaluation during training (default 8)")
    g.add_argument("--batch-size", default=None, help="samples per PPO iteration (default 4096)")
    g.add_argument("--minibatch-size", default=None, help="samples per gradient step (default 256, at most the batch)")
    g.add_argument("--final-episodes", default=None, help="episodes of the evaluation after each run (default 32)")
    g.add_argument("--device", default=None, help="torch device of the learner (default cpu)")
    g.add_argument("--torch-threads", default=None, help="learner's torch threads (default 0: every core; give 1 when two grids share the cores)")


def _count(flag: str, text, minimum: int = 1) -> int:
    """'600', '500k', '2M', '1e6' -> int >= minimum; SfvError naming the flag otherwise."""
    raw = str(text).strip()
    try:
        value = whole_number(raw)
    except ValueError:
        raise SfvError(f"--{flag}: expected a whole number (600, 500k, 2M), got {raw!r}") from None
    if value < minimum:
        raise SfvError(f"--{flag} must be {'positive' if minimum == 1 else f'>= {minimum}'}, got {raw!r}")
    return value


def _names(flag: str, text: str) -> list[str]:
    names = list(dict.fromkeys(part.strip() for part in str(text).split(",") if part.strip()))
    if not names:
        raise SfvError(f"--{flag}: empty list, got {text!r}")
    return names


def split_budget(text: str, default: int) -> tuple[str, int]:
    """'backflip@20M' -> ('backflip', 20000000); 'walk' -> ('walk', default)."""
    name, at, budget = str(text).rpartition("@") if "@" in str(text) else (str(text), "", "")
    if not at:
        return str(text), default
    if not name:
        raise SfvError(f"--skills {text!r}: no motion before '@'")
    raw = budget.strip()
    if raw == "spec":
        return name, spec_budget(name, text)
    try:
        value = whole_number(raw)
    except ValueError:
        raise SfvError(f"--skills {text!r}: the budget after '@' must be a whole number of samples (500k, 20M), got {raw!r}") from None
    if value < 1:
        raise SfvError(f"--skills {text!r}: the budget after '@' must be positive")
    return name, value


def skill_specs() -> dict[str, int]:
    """{clip: its run spec's budget} of the registered humanoid skill specs (the skills table)."""
    from services.specs import specs_for

    return {spec.settings["motion"].split(":", 1)[1]: spec.settings["samples"] for spec in specs_for("train").values()
            if str(spec.settings.get("motion", "")).startswith("deepmimic:") and "env.character" not in spec.settings
            and "init" not in spec.settings}


def spec_budget(name: str, text: str) -> int:
    """'cartwheel@spec': the budget of the clip's run spec."""
    budgets = skill_specs()
    clip = name.removeprefix("deepmimic:")
    if clip not in budgets:
        raise SfvError(f"--skills {text!r}: no run spec for {clip!r} (specs: {', '.join(budgets)})")
    return budgets[clip]


def _skill(text: str) -> tuple[str, str]:
    """A skill flag entry (without its @BUDGET) -> (motion for TrainConfig, short clip name); validates by loading it."""
    from actors.motion.formats.io import DEEPMIMIC_CLIPS, load_motion

    motion = f"deepmimic:{text}" if text in DEEPMIMIC_CLIPS else text
    try:
        load_motion(motion)
    except SfvError as exc:
        raise SfvError(f"--skills {text!r}: {exc}") from None
    if motion.startswith("deepmimic:"):
        clip = motion.split(":", 1)[1]
    else:
        motion = str(Path(motion).resolve())
        clip = Path(motion).stem
    return motion, re.sub(r"[^A-Za-z0-9_.-]+", "-", clip) or "motion"


def config_from_args(args) -> LearningConfig:
    """Every learning flag checked (SfvError naming the flag), before anything is written."""
    defaults = LearningConfig()
    if not args.out_dir:
        raise SfvError("--out-dir is required for --suite learning (learning.json, learning.png and runs/ go there)")
    if getattr(args, "out", None) is not None:
        raise SfvError("--out: the learning suite writes OUT_DIR/learning.json; give --out-dir instead")
    inits = _names("inits", args.inits) if args.inits is not None else list(defaults.inits)
    bad = [i for i in inits if i not in INITS]
    if bad:
        raise SfvError(f"--inits {bad[0]!r}: not an initial-state strategy; choose from {', '.join(INITS)}")
    if args.seeds is not None:
        seeds = [_count("seeds", s, minimum=0) for s in _names("seeds", args.seeds)]
    else:
        seeds = [getattr(args, "seed", 0) or 0]
    config = LearningConfig(
        out_dir=Path(args.out_dir), inits=tuple(inits), seeds=tuple(dict.fromkeys(seeds)),
        samples=_count("samples", args.samples) if args.samples is not None else defaults.samples,
        workers=_count("workers", args.workers) if args.workers is not None else defaults.workers,
        envs_per_worker=_count("envs-per-worker", defaults.envs_per_worker if getattr(args, "envs_per_worker", None) is None
                               else args.envs_per_worker),
        runner=_runner(args), device=args.device or defaults.device,
        torch_threads=_count("torch-threads", args.torch_threads, minimum=0) if args.torch_threads is not None else defaults.torch_threads,
        batch_size=_count("batch-size", args.batch_size) if args.batch_size is not None else None,
        minibatch_size=_count("minibatch-size", args.minibatch_size) if args.minibatch_size is not None else None,
        eval_every=_count("eval-every", args.eval_every, minimum=0) if args.eval_every is not None else None,
        eval_episodes=_count("eval-episodes", args.eval_episodes) if args.eval_episodes is not None else None,
        final_episodes=_count("final-episodes", args.final_episodes) if args.final_episodes is not None else defaults.final_episodes,
        physics_hz=getattr(args, "physics_hz", None),
        progress=not getattr(args, "quiet", False) and sys.stderr.isatty(),
    )
    if config.physics_hz is not None and not config.physics_hz > 0:
        raise SfvError(f"--physics-hz must be positive, got {config.physics_hz}")
    skills = _names("skills", args.skills) if args.skills is not None else list(defaults.skills)
    if skills == ["all"]:  # every DeepMimic humanoid3d clip
        from actors.motion.formats.io import DEEPMIMIC_CLIPS

        skills = list(DEEPMIMIC_CLIPS)
    elif skills == ["specs"]:  # every skill spec at its own budget (the skills table)
        skills = [f"{clip}@spec" for clip in skill_specs()]
    config.skills = tuple(dict.fromkeys(skills))
    for cell in cells(config):  # loads every skill (unknown ones fail here) and checks every run's settings
        train_config(config, cell)
    return config


def _runner(args) -> str:
    runner = getattr(args, "runner", None)
    if args.serial and runner not in (None, "in_process"):
        raise SfvError(f"--serial runs the workers in this process; it cannot go with --runner {runner}")
    return "in_process" if args.serial else (runner or "ray")


def cells(config: LearningConfig) -> list[Cell]:
    """The grid in run order: per skill and seed, the inits one after the other (a cut-short grid stays comparable)."""
    budgeted = [split_budget(s, config.samples) for s in config.skills]
    resolved = [(*_skill(name), budget) for name, budget in budgeted]
    clips: dict[str, str] = {}
    for (motion, clip, _), text in zip(resolved, config.skills):
        if clip in clips:
            taken = "twice" if clips[clip] == motion else f"by {clips[clip]}"
            raise SfvError(f"--skills {text!r}: its run name {clip!r} is taken {taken}; give each skill once")
        clips[clip] = motion
    return [Cell(motion, clip, init, seed, budget) for motion, clip, budget in resolved
            for seed in config.seeds for init in config.inits]


def train_config(config: LearningConfig, cell: Cell):
    from actors.character.humanoid import PhysicsConfig
    from services.training.config import TrainConfig

    train = TrainConfig(motion=cell.skill, out=str(run_dir_of(config, cell)), workers=config.workers,
                        envs_per_worker=config.envs_per_worker, init=cell.init, samples=cell.samples, seed=cell.seed,
                        runner=config.runner, device=config.device, eval_every=config.resolved_eval_every(cell.samples),
                        torch_threads=config.torch_threads)
    train.ppo = dataclasses.replace(train.ppo, seed=cell.seed)
    if config.eval_episodes is not None:
        train.eval_episodes = config.eval_episodes
    if config.batch_size is not None:
        train.ppo.batch_size = config.batch_size
        if config.minibatch_size is None:
            train.ppo.minibatch_size = min(train.ppo.minibatch_size, config.batch_size)
    if config.minibatch_size is not None:
        if config.minibatch_size > train.ppo.batch_size:
            raise SfvError(f"--minibatch-size {config.minibatch_size} exceeds the batch size {train.ppo.batch_size}")
        train.ppo.minibatch_size = config.minibatch_size
    if config.physics_hz is not None:
        train.env = dataclasses.replace(train.env, physics=PhysicsConfig(physics_hz=config.physics_hz))
        try:
            train.env.substeps  # noqa: B018  a rate that is no multiple of the control rate
        except ValueError as exc:
            raise SfvError(f"--physics-hz: {exc}") from None
    train.validate()  # names the flag: --workers must be positive, ...
    return train


def run_dir_of(config: LearningConfig, cell: Cell) -> Path:
    return Path(config.out_dir) / RUNS_DIR / cell.name


def _dig(d: dict, path: tuple[str, ...]):
    for key in path:
        if not isinstance(d, dict):
            return None
        d = d.get(key)
    return d


def check_existing(config: LearningConfig, grid: list[Cell]) -> dict:
    """The results so far (a fresh document when there is none); SfvError if a run directory holds
    another run, or a run without a record was trained with other settings than its cell's."""
    from services.bench.run_history import setting_differences
    from services.training.run_dir import CONFIG_FILE

    doc = _read_results(config)
    for cell in grid:
        saved_path = run_dir_of(config, cell) / CONFIG_FILE
        if not saved_path.is_file():
            continue
        try:
            saved = json.loads(saved_path.read_text())
        except (OSError, ValueError) as exc:
            raise SfvError(f"{saved_path}: unreadable ({exc}); remove the run directory to retrain it") from None
        wanted = train_config(config, cell).to_dict()
        for key, path in IDENTITY.items():
            if _dig(saved, path) != _dig(wanted, path):
                raise SfvError(f"{saved_path.parent}: trained with {key} {_dig(saved, path)!r}, this run asks for "
                               f"{_dig(wanted, path)!r}; use another --out-dir")
        if cell.name not in doc["runs"]:  # moved in from `sfv train`: the same settings, or it is not this cell's run
            differing = setting_differences(_as_loaded(saved), wanted)
            if differing:
                shown = ", ".join(f"{name} {_dig(saved, tuple(name.split('.')))!r} (wanted {_dig(wanted, tuple(name.split('.')))!r})"
                                  for name in differing[:4])
                raise SfvError(f"{saved_path.parent}: has no record in {RESULTS_FILE} and was trained with other settings: "
                               f"{shown}{' ...' if len(differing) > 4 else ''}; move it away or use another --out-dir")
    return doc


def _as_loaded(saved: dict) -> dict:
    """A saved run config as `sfv train --resume` reads it: the settings added since it was written
    filled with what it was trained with (`TrainConfig.from_dict`); as written if it does not load."""
    from services.training.config import TrainConfig

    try:
        return TrainConfig.from_dict(saved).to_dict()
    except (ValueError, TypeError):  # a config from another version (ConfigError is a ValueError): compared as written
        return saved


def _read_results(config: LearningConfig) -> dict:
    path = Path(config.out_dir) / RESULTS_FILE
    if not path.exists():
        return {"format": FORMAT, "runs": {}}
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise SfvError(f"{path}: unreadable ({exc}); move it away to start afresh") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT or not isinstance(doc.get("runs"), dict):
        raise SfvError(f"{path}: not a learning-suite result (format {FORMAT}); move it away or use another --out-dir")
    return doc


# ---------------------------------------------------------------------- the runs
def config_summary(config: LearningConfig, train) -> dict:
    return {"motion": train.motion, "init": train.init, "seed": train.seed, "samples": train.samples,
            "workers": train.workers, "envs_per_worker": train.envs_per_worker, "serial": train.serial, "runner": train.runner,
            "device": train.device, "batch_size": train.ppo.batch_size, "minibatch_size": train.ppo.minibatch_size,
            "update_epochs": train.ppo.update_epochs, "policy_lr": train.ppo.policy_lr,
            "physics_hz": train.env.physics.physics_hz, "control_hz": train.env.control_hz,
            "eval_every": getattr(train, "eval_every", None), "eval_episodes": getattr(train, "eval_episodes", None),
            "final_episodes": config.final_episodes}


def run_grid(config: LearningConfig, grid: list[Cell], doc: dict, command: str | None, log, emit) -> tuple[dict, int]:
    """Train, evaluate and record every cell not yet complete; returns the document written and how many runs failed."""
    from services.bench.runner import machine

    out_dir = Path(config.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    now = _now()
    doc.setdefault("created", now)
    info = machine()
    doc.update(format=FORMAT, command=command, updated=now, machine=info, threshold=config.threshold)
    started_ray = False
    if config.runner == "ray":
        started_ray = _start_ray(config.workers)
    failures = 0
    try:
        for cell in grid:
            entry = doc["runs"].get(cell.name)
            if entry and entry.get("status") == "complete" and entry.get("config", {}).get("samples", 0) >= cell.samples:
                log(f"{cell.name}: complete in {RESULTS_FILE} ({entry.get('samples')} samples), skipped")
                continue
            entry = _run_cell(config, cell, entry, doc, info, log)
            if entry["status"] == "complete":
                emit(result_line(entry))
            else:
                failures += 1
                emit(f"{cell.skill} {cell.init} seed {cell.seed}: FAILED: {entry.get('error')}")
    finally:
        if started_ray:
            import ray

            ray.shutdown()
    _plot_safely(doc, out_dir / PLOT_FILE, config.skills, log)
    return doc, failures


def _run_cell(config: LearningConfig, cell: Cell, previous: dict | None, doc: dict, info: dict, log) -> dict:
    from services.training.driver import Trainer
    from services.training.evaluation import evaluate_run
    from services.training.run_dir import checkpoint_files

    run_dir = run_dir_of(config, cell)
    train = train_config(config, cell)
    resume = bool(checkpoint_files(run_dir))
    if not resume:
        _clear_unfinished(run_dir)  # killed before its first checkpoint: start clean, no stale metrics rows
    earlier_wall = _earlier_wall(previous, run_dir) if resume else 0.0
    resumes = int((previous or {}).get("resumes") or 0) + (1 if resume else 0)
    entry = {"name": cell.name, "skill": cell.skill, "init": cell.init, "seed": cell.seed,
             "run_dir": str(Path(RUNS_DIR) / cell.name), "config": config_summary(config, train),
             "resumes": resumes, "machine": info}
    log(f"{cell.name}: {'resuming from its newest checkpoint' if resume else 'training'} to {cell.samples:,} samples")
    trainer = Trainer(train, resume=resume, progress=config.progress)
    start = time.perf_counter()
    try:
        trainer.run()
    except Exception as exc:  # one run's fault (non-finite update, dead workers): record it, go on with the grid
        log(traceback.format_exc().rstrip())
        entry.update(status="failed", error=str(exc).splitlines()[0][:500] if str(exc) else type(exc).__name__,
                     samples=trainer.samples, wall_s=earlier_wall + time.perf_counter() - start, finished=_now())
        _save(doc, cell, entry, config)
        return entry
    except BaseException:  # interrupted: keep the time spent so the resumed run's wall time adds up
        entry.update(status="incomplete", samples=trainer.samples, wall_s=earlier_wall + time.perf_counter() - start)
        _save(doc, cell, entry, config)
        raise
    finally:
        gc.collect()  # drop the run's workers (Ray actor handles) before the next run
    wall = earlier_wall + time.perf_counter() - start
    entry.update(samples=int(trainer.samples), wall_s=wall)
    start = time.perf_counter()
    try:
        evaluation = evaluate_run(run_dir, episodes=config.final_episodes)
    except Exception as exc:  # trained, not evaluated: a rerun resumes (nothing left to train) and evaluates again
        log(traceback.format_exc().rstrip())
        entry.update(status="failed", error=f"evaluation: {str(exc).splitlines()[0][:500] if str(exc) else type(exc).__name__}",
                     finished=_now())
        _save(doc, cell, entry, config)
        return entry
    eval_s = time.perf_counter() - start
    curve = read_curve(run_dir)
    reached, source = samples_to_threshold(curve, trainer.samples, evaluation.get("normalized_return"), config.threshold)
    entry.update(status="complete", samples=int(trainer.samples), wall_s=wall, eval_s=eval_s,
                 samples_per_s=trainer.samples / max(wall, 1e-9), finished=_now(), eval=_plain(evaluation),
                 curve=curve, samples_to_threshold=reached, threshold_source=source)
    _save(doc, cell, entry, config)
    return entry


def _earlier_wall(previous: dict | None, run_dir: Path) -> float:
    """Training seconds before this invocation: the record's, or, for a run without one (moved in
    from `sfv train`, or killed before its record was written), what its metrics' time stamps say."""
    if previous and previous.get("wall_s"):
        return float(previous["wall_s"])
    from services.bench.run_history import training_seconds
    from services.training.run_dir import read_metrics

    return float(training_seconds([row for row in read_metrics(run_dir) if "samples" in row]) or 0.0)


def _clear_unfinished(run_dir: Path) -> None:
    from services.training.run_dir import CONFIG_FILE, METRICS_FILE

    for name in (METRICS_FILE, CONFIG_FILE, "learning_curve.png"):
        (run_dir / name).unlink(missing_ok=True)
    shutil.rmtree(run_dir / "tb", ignore_errors=True)


def _save(doc: dict, cell: Cell, entry: dict, config: LearningConfig) -> None:
    """Record one run. Two suite invocations may share an out-dir (two streams of clips on two
    cores): under a lock, the runs another invocation recorded since this one read the file are
    merged in rather than overwritten; this invocation's own cell always wins."""
    import fcntl

    from services.training.run_dir import write_json_atomic

    path = Path(config.out_dir) / RESULTS_FILE
    with open(path.with_name(RESULTS_FILE + ".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            on_disk = json.loads(path.read_text()) if path.exists() else {}
        except (OSError, ValueError):
            on_disk = {}  # a torn or foreign file: this document replaces it, as before
        if isinstance(on_disk, dict) and isinstance(on_disk.get("runs"), dict):
            for name, other in on_disk["runs"].items():
                if name != cell.name:
                    doc["runs"][name] = other
        doc["runs"][cell.name] = entry
        doc["updated"] = _now()
        write_json_atomic(path, doc)


def _start_ray(workers: int) -> bool:
    from services.ray_session import connect_ray

    return connect_ray(num_cpus=workers, log_to_driver=False)


def _plain(value):
    """JSON-safe copy: numpy scalars and arrays to Python, NaN/inf to None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "tolist"):
        return _plain(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


# -------------------------------------------------------------------- the command
def command_line(config: LearningConfig) -> str:
    parts = ["sfv", "bench", "--suite", "learning", "--out-dir", str(config.out_dir), "--skills", ",".join(config.skills),
             "--inits", ",".join(config.inits), "--seeds", ",".join(map(str, config.seeds)), "--samples", str(config.samples),
             "--workers", str(config.workers), "--envs-per-worker", str(config.envs_per_worker)]
    if config.serial:
        parts.append("--serial")
    elif config.runner != "ray":
        parts += ["--runner", config.runner]
    for flag, value in (("--batch-size", config.batch_size), ("--minibatch-size", config.minibatch_size),
                        ("--eval-every", config.eval_every), ("--eval-episodes", config.eval_episodes), ("--physics-hz", _non_default_physics_hz(config))):
        if value is not None:
            parts += [flag, f"{value:g}" if isinstance(value, float) else str(value)]
    if config.final_episodes != LearningConfig().final_episodes:
        parts += ["--final-episodes", str(config.final_episodes)]
    if config.device != "cpu":
        parts += ["--device", config.device]
    if config.torch_threads:
        parts += ["--torch-threads", str(config.torch_threads)]
    return " ".join(shlex.quote(p) for p in parts)


def _non_default_physics_hz(config: LearningConfig) -> float | None:
    from actors.character.humanoid import PhysicsConfig

    return None if config.physics_hz in (None, PhysicsConfig().physics_hz) else config.physics_hz


def run_learning_command(args) -> int:
    """`sfv bench --suite learning ...`: 0 when every run completed, 1 when one failed, 2 (SfvError) for bad flags."""
    config = config_from_args(args)
    grid = cells(config)
    doc = check_existing(config, grid)
    quiet = getattr(args, "quiet", False)
    log = (lambda message: None) if quiet else (lambda message: print(message, file=sys.stderr, flush=True))
    emit = lambda line: print(line, flush=True)  # noqa: E731
    doc, failures = run_grid(config, grid, doc, command_line(config), log, emit)
    print()
    print(markdown_table(doc, config.skills))
    print(f"\nwritten to {Path(config.out_dir) / RESULTS_FILE} and {Path(config.out_dir) / PLOT_FILE}")
    return 1 if failures else 0
