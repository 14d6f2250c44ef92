"""Record the distillation dataset: each expert rolled out with action noise (004 §3.3).

004 §3.3: the motor module is trained "to model state-action sequences (trajectories) generated
by executing the various single-skill experts policies while adding independent Gaussian noise
to the actions". Per clip (one Ray task each, as many at once as the cores):
- episodes start throughout the clip: episode e at phase frac(e * 0.618...) (a low-discrepancy
  sequence, so any number of episodes covers the clip evenly), from the reference state there;
- each step the expert's mean action a* is perturbed by independent N(0, noise_std^2) noise
  per component in normalised action units (default 0.1, the experts' own exploration std);
  the applied action drives the env; the PD targets of a* (what `actors/character/actions.py` makes of it:
  reference target + residual, clipped) are the regression target, so the dataset holds the
  expert's *correction* from the perturbed states the noise leads to;
- an episode ends at a fall, the clip's end or `episode_steps` (short episodes keep the starts
  spread); episodes continue until the clip has `steps` rows.
The rows are the fields of `services/motor/dataset.py`. Each task writes its chunks into
DIR/.parts/<clip>/; the driver then numbers them and writes the manifest last.
"""
from __future__ import annotations

import json
import math
import shutil
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from learner.errors import SfvError
from services.motor.dataset import FIELDS, MANIFEST, chunk_name, write_chunk, write_manifest

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
PARTS = ".parts"


@dataclass(frozen=True)
class RecordConfig:
    steps_per_clip: int = field(default=30_000, metadata={"help": "control steps recorded per expert clip"})
    noise_std: float = field(default=0.1, metadata={"help": "std of the independent Gaussian noise on each normalised action component (004 §3.3)"})
    episode_steps: int = field(default=150, metadata={"help": "longest recorded episode (control steps); shorter episodes spread the starts over the clip"})
    chunk_steps: int = field(default=10_000, metadata={"help": "most rows per npz chunk (episodes are not split)"})
    noise_seed: int = field(default=0, metadata={"help": "seed of the action noise and episode seeds; clip i uses noise_seed + i"})

    def __post_init__(self):
        if self.steps_per_clip < 1 or self.episode_steps < 1 or self.chunk_steps < 1:
            raise SfvError("record: steps per clip, episode steps and chunk steps must be positive")
        if not (math.isfinite(self.noise_std) and self.noise_std >= 0):
            raise SfvError(f"record: the action noise std must be a finite number >= 0, got {self.noise_std}")


def _episode_rows(capacity: int) -> dict[str, np.ndarray]:
    return {name: np.zeros((capacity, *shape), dtype=dtype) for name, (dtype, shape) in FIELDS.items()}


def record_clip(experts_dir: str, clip: str, clip_index: int, out_dir: str, config: RecordConfig) -> list[dict]:
    """Roll the expert of `clip` (`services/experts/library.py`: a run directory, or a mirrored
    expert for `<clip>_mirror`) out until `config.steps_per_clip` rows; chunks into `out_dir`.

    Returns the chunk descriptions (file name within out_dir, steps, episodes)."""
    from actors.character.actions import ActionMapper
    from actors.envs.tasks.future_reference import FutureReference
    from services.experts.library import load_expert

    policy = load_expert(experts_dir, clip, max_batch=1)
    env = policy.make_env()
    future = FutureReference(env.track, env.humanoid)
    mean_mapper = ActionMapper(env.config.action_parameterisation, env.config.residual_action_scale)
    rng = np.random.default_rng(config.noise_seed + clip_index)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = _episode_rows(config.chunk_steps + config.episode_steps)
    obs_row = np.zeros((1, env.obs_dim), np.float32)
    applied = np.zeros((1, env.action_space.shape[0]), np.float32)
    chunks, used, episode, total = [], 0, 0, 0
    while total < config.steps_per_clip:
        obs, _ = env.reset(seed=config.noise_seed + episode, options={"init": "rsi", "phase": (episode * GOLDEN) % 1.0})
        obs_row[0] = obs
        limit = min(config.episode_steps, env.max_episode_steps, config.steps_per_clip - total)
        for step in range(limit):
            i = used + step
            future(env.data, env.row, env.root_sync.offset, rows["proprio"][i], rows["future"][i])
            mean = policy.mean(obs_row)
            mean_mapper.targets_batch(mean, rows["mean_targets"][i:i + 1], env.reference_targets(env.row + 1))
            np.add(mean, config.noise_std * rng.standard_normal(applied.shape, dtype=np.float32), out=applied)
            rows["row"][i], rows["step"][i] = env.row, step
            obs, reward, terminated, truncated, _ = env.step(applied[0])
            rows["applied_targets"][i] = env.data.ctrl
            rows["reward"][i] = reward
            obs_row[0] = obs
            if terminated or truncated:
                step += 1
                break
        else:
            step = limit
        rows["clip"][used:used + step] = clip_index
        rows["episode"][used:used + step] = episode
        used += step
        total += step
        episode += 1
        if used >= config.chunk_steps or total >= config.steps_per_clip:
            name = f"part_{len(chunks):05d}.npz"
            write_chunk(out / name, {key: value[:used] for key, value in rows.items()})
            chunks.append({"file": name, "steps": used, "episodes": int(len(np.unique(rows["episode"][:used])))})
            used = 0
    (out / "done.json").write_text(json.dumps(chunks))
    return chunks


def expert_clips(experts_dir: Path, clips: list[str] | None) -> list[str]:
    """The clips to record, checked against `experts_dir` (`<clip>_mirror` needs `<clip>`'s run);
    every expert run with a checkpoint when `clips` is None. humanoid3d experts only: a G1
    expert is a one-line SfvError (the dataset's fields have the humanoid's sizes)."""
    from actors.character.mirror import MIRROR_SUFFIX
    from services.experts.library import humanoid_experts_only

    experts_dir = Path(experts_dir)
    if not experts_dir.is_dir():
        raise SfvError(f"{experts_dir}: experts directory not found")
    if clips is None:
        clips = sorted(p.name for p in experts_dir.iterdir() if (p / "config.json").is_file() and any(p.glob("checkpoint_*.pt")))
    for clip in clips:
        run = experts_dir / clip.removesuffix(MIRROR_SUFFIX)
        if not (run / "config.json").is_file():
            raise SfvError(f"{run}: no expert run directory for clip {clip!r}")
    if not clips:
        raise SfvError(f"{experts_dir}: no expert run directories")
    humanoid_experts_only(experts_dir, clips)  # the dataset's sizes are the humanoid's: a G1 expert is refused
    return list(clips)


def record_dataset(experts_dir: Path, clips: list[str], out: Path, config: RecordConfig, progress: bool = True) -> dict:
    """Record every clip (Ray tasks, resumable per clip) and assemble `out` with its manifest."""
    import ray
    from tqdm import tqdm

    from services.ray_session import get_results, ray_session

    out = Path(out)
    if (out / MANIFEST).exists():
        raise SfvError(f"{out}: a dataset is already there (remove it or pick another directory)")
    parts = out / PARTS
    pending = [i for i, clip in enumerate(clips) if not (parts / clip / "done.json").is_file()]
    if pending:
        with ray_session():
            task = ray.remote(num_cpus=1, max_retries=0)(record_clip)
            refs = {task.remote(str(experts_dir), clips[i], i, str(parts / clips[i]), config): i for i in pending}
            with tqdm(total=len(refs), unit="clip", desc="record", disable=not progress) as bar:
                while refs:
                    ready, _ = ray.wait(list(refs), num_returns=1)
                    get_results(ready)
                    bar.set_postfix_str(clips[refs.pop(ready[0])])
                    bar.update()
    chunks = []
    for i, clip in enumerate(clips):
        for part in json.loads((parts / clip / "done.json").read_text()):
            name = chunk_name(len(chunks))
            (parts / clip / part["file"]).replace(out / name)
            chunks.append({**part, "file": name, "clip": i})
    manifest = write_manifest(out, clips, chunks, {"experts": str(experts_dir),
                                                   "record": asdict(config), "future_steps": 5})
    shutil.rmtree(parts, ignore_errors=True)
    return manifest
