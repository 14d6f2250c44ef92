"""The training driver: rollout workers -> PPO learner -> weights -> workers, ASI alongside.

Roles follow RLlib's new stack / sample-factory: `RolloutWorker`s (actors/) only sample,
`PPOLearner` (learner/) only updates, a `WorkerRunner` (runners/: in this process, Ray
actors, or plain processes; `--runner`) carries weights out and trajectories back as numpy
arrays, and this driver runs the loop: collect, check, update, record, evaluate, checkpoint.

Faults (docs/faults.md has the measured numbers): the Ray runner restarts dead and hung
workers and reissues their shares (`worker_failures`, `worker_restarts` in metrics.jsonl). A
worker that raises SfvError (ASI server gone for longer than `asi_outage_s`, a request the
server refuses) stops training with that message. Every batch is checked to come from one
policy version (synchronous loop) or from versions at most `--max-policy-lag` old
(asynchronous loop, `async_collector.py`). A non-finite observation, reward or gradient stops training with a message
naming it, before any checkpoint could be poisoned. `--resume` skips (with a warning) a
newest checkpoint that fails its integrity check and resumes from the one before.
"""
from __future__ import annotations

import hashlib
import logging
import math
import time
from pathlib import Path

import numpy as np

from actors.envs.imitation_env import ImitationEnv
from actors.character.characters import character_named
from actors.motion.character_reference import load_reference
from actors.rollout.worker import RolloutWorker, WorkerSpec
from actors.character.humanoid3d import HUMANOID3D
from actors.envs.terrain_curriculum import LEVELS as TERRAIN_LEVELS
from learner.checkpoint import checkpoint_path, latest_checkpoint, load_checkpoint, save_checkpoint
from learner.errors import NonFiniteError, SfvError, TrainingStopped
from learner.ppo import PPOLearner
from learner.schedule import decaying_help, linear_anneal
from learner.tuple_sampling import select_tuples
from services.ray_session import connect_ray
from services.training.asi_connection import ASIConnection
from services.training.async_collector import AsyncCollector
from services.training.config import TrainConfig
from services.training.run_dir import (
    BEST_CHECKPOINT,
    CONFIG_FILE,
    MetricsLog,
    checkpoint_files,
    drop_metrics_after,
    remove_stale_temp_files,
    write_json_atomic,
)
from services.training.runners import WorkerFaults, WorkerRunner, make_runner
from services.training.stop_signals import StopSignals

log = logging.getLogger("sfv.train")
TRAJECTORY_KEYS = ("obs", "next_obs", "actions", "logp", "rewards", "terminated", "truncated")


def default_job_id(config: TrainConfig) -> str:
    digest = hashlib.sha1(str(Path(config.out).resolve()).encode()).hexdigest()[:10]
    return f"{Path(config.out).name or 'run'}-{digest}"


class Trainer:
    worker_class = RolloutWorker  # what the runner instantiates (a test's subclass may wrap it)

    def __init__(self, config: TrainConfig, resume: bool = False, progress: bool = True):
        if config.ppo.reward_max is not None:  # value targets are bounded by this env's own reward
            config.ppo.reward_max = config.env.max_reward
        config.validate()
        self.config = config
        self.resume = resume
        self.progress = progress
        self.run_dir = Path(config.out)
        self.faults = WorkerFaults()
        self.runner: WorkerRunner | None = None
        self.collector: AsyncCollector | None = None  # the asynchronous loop's (max_policy_lag >= 1)
        self.samples = 0
        self.iteration = 0
        self.best_eval: float | None = None  # the best periodic evaluation's normalised return (best.pt)
        self.terrain_level: float | None = None  # the terrain curriculum's mean level over the newest batch's envs
        self.asi_drift: ASIDrift | None = None
        self.stop: StopSignals | None = None  # installed around the loop (`run`)

    # ------------------------------------------------------------------ setup
    def _prepare_run_dir(self) -> dict | None:
        self.run_dir.mkdir(parents=True, exist_ok=True)
        for name in remove_stale_temp_files(self.run_dir):  # a write the killed process never finished
            log.warning("%s: removed %s, left by an interrupted write", self.run_dir, name)
        existing = checkpoint_files(self.run_dir)
        if existing and not self.resume:
            raise SfvError(f"{self.run_dir}: holds checkpoints already; pass --resume to continue or choose another --out")
        latest = latest_checkpoint(self.run_dir) if self.resume else None
        corrupt = [path for path in existing if latest is None or path.name > latest.name]
        for path in corrupt:  # newer than the one resumed from, yet unreadable: say so, never load it
            log.warning("skipping checkpoint %s: %s", path.name, _load_error(path))
        if self.resume and latest is None:
            detail = f" ({_load_error(corrupt[-1])})" if corrupt else ""
            raise SfvError(f"{self.run_dir}: --resume given but there is no valid checkpoint to resume from{detail}")
        if self.config.job_id is None:
            self.config.job_id = default_job_id(self.config)
        write_json_atomic(self.run_dir / CONFIG_FILE, self.config.to_dict())
        return load_checkpoint(latest) if latest is not None else None

    def _reference_table(self, motion):
        env = ImitationEnv(motion, self.config.env)
        rows = np.arange(env.track.start_steps)
        states = np.stack([env.reference_state_vector(r) for r in rows])
        return env, states, env.track.phase[rows]

    # ------------------------------------------------------------- collection
    def _horizon_s(self) -> float | None:
        """The episode-length curriculum's limit now (DeepMimic: 0.5 s annealed to 20 s over
        32 M samples); None when the curriculum is off or over."""
        c = self.config
        if c.curriculum_start_s <= 0 or self.samples >= c.curriculum_samples:
            return None
        return linear_anneal(c.curriculum_start_s, c.env.horizon_s, self.samples, c.curriculum_samples)

    def _residual_strength(self) -> float | None:
        """The residual root wrench's strength now (`residual_force_final`); None without a decay."""
        c = self.config
        final = getattr(c, "residual_force_final", 1.0)  # task trainings (TaskConfig) have no wrench
        if final >= 1.0 or getattr(c.env, "residual_force", 0.0) <= 0:
            return None
        # the first quarter learns the clip with the whole wrench, the middle half hands it over
        # to the body, the last quarter trains (and chooses best.pt) at the final strength
        return decaying_help(final, self.samples, c.samples)

    def _help_settled(self) -> bool:
        """Evaluations compete for best.pt only at the final strength: an early, helped policy
        would win on NR and be played with a help it no longer has."""
        strength = self._residual_strength()
        return strength is None or strength <= getattr(self.config, "residual_force_final", 1.0) + 1e-9

    def _collect(self, weights, version: int, steps: int) -> list[dict]:
        horizon, strength = self._horizon_s(), self._residual_strength()
        options = {} if horizon is None else {"horizon_s": horizon}  # RolloutWorker.sample's optional arguments
        if strength is not None:
            options["residual_strength"] = strength
        if self.collector is not None:
            return self.collector.next_batch(weights, version, options)
        return self.runner.collect(weights, version, steps, options)

    def _merge(self, results: list[dict], version: int) -> dict:
        versions = {int(r["policy_version"]) for r in results}
        oldest = version - self.config.policy_lag
        if not all(oldest <= v <= version for v in versions):
            raise SfvError(f"internal: a batch mixes policy versions {sorted(versions)} (expected {oldest}..{version})")
        batch = {k: np.concatenate([r[k] for r in results], axis=1) for k in TRAJECTORY_KEYS}
        batch["frames"] = np.concatenate([r["frames"] for r in results], axis=1)
        if "terrain_levels" in results[0]:  # each env's curriculum level after its share: the checkpoint keeps the mean for --resume
            self.terrain_level = float(np.mean(np.concatenate([r["terrain_levels"] for r in results])))
        for k in results[0]:
            if k.startswith("episode_"):
                batch[k] = np.concatenate([r[k] for r in results])
        batch["asi_version"] = max(int(r["asi_version"]) for r in results)
        batch["asi_dropped_reports"] = sum(int(r["asi_dropped_reports"]) for r in results)
        batch["policy_versions"] = sorted(versions)
        lags = [version - int(r["policy_version"]) for r in results]
        batch["policy_lag"] = max(lags)  # the learner corrects for it (decoupled clipping) when > 0
        batch["policy_lag_mean"] = float(np.mean(lags))
        batch["worker_indices"] = [int(r["worker_index"]) for r in results]
        return batch

    # -------------------------------------------------------------------- run
    def close(self) -> None:
        """Stop the workers the runner started (processes, Ray actors); a second call does nothing."""
        if self.runner is not None:
            self.runner.close()
            self.runner = None

    def __enter__(self) -> "Trainer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def run(self) -> dict:
        config = self.config
        # The motion and the env (its scene file) first: a bad file is one line with nothing written.
        motion = load_reference(config.motion, character_named(config.env.character))  # a clip for a robot: retargeted once, here
        env, ref_states, ref_phases = self._reference_table(motion)
        checkpoint = self._prepare_run_dir()
        self.track_rows = env.track.rows  # the frame range of adaptive tuple sampling's coverage
        device = check_learner_device(config.device)
        _set_torch_threads(config)
        learner = PPOLearner(env.observation_space.shape[0], env.action_space.shape[0], config.ppo, device=device)
        asi_version = 0
        if checkpoint is not None:
            asi_version = self._restore(learner, checkpoint)
        elif config.start_from:
            self._start_from(learner, config.start_from)
        learner.set_progress(self.samples)
        if config.runner == "ray" and not (config.ray_address or config.asi_address or config.redis_url):
            # A local Ray before the embedded ASI server: Ray forks its GCS and raylet (with a
            # preexec_fn, so Python runs in the child), and a fork while the server's gRPC threads
            # run crashed the child now and then; twice in a row failed a clean-clone test run.
            connect_ray(None, num_cpus=max(config.workers, 1))
        # The ASI server (and its Redis) first: a wrong address fails in seconds, before Ray starts.
        with ASIConnection(config) as asi:
            info = asi.create_job(ref_states, ref_phases)
            spec = WorkerSpec(motion, config.env, config.envs_per_worker, config.init, config.seed, config.ppo.gamma,
                              asi.address, config.job_id, asi.token, asi_tls_ca=config.asi_tls_ca,
                              asi_outage_s=config.asi_outage_s, handover_states=_handover_states(config),
                              handover_share=config.handover_share, first_frame_share=config.first_frame_share,
                              start_phase_spread=config.asi_phase_spread / config.asi_components if config.init == "asi" else 0.0,
                              terrain_start_level=self._terrain_start_level())
            self.runner = make_runner(config, self.worker_class, self.faults)
            self.runner.start(spec)
            if config.policy_lag > 0:
                self.collector = AsyncCollector(self.runner, config.steps_per_worker, config.policy_lag,
                                                shares_per_batch=config.workers, timeout_s=config.worker_timeout_s)
            self.asi_drift = ASIDrift(asi.client) if config.init == "asi" else None
            metrics = MetricsLog(self.run_dir, resumed_at_samples=self.samples if checkpoint is not None else None)
            try:
                with StopSignals() as stop:  # SIGTERM / SIGINT: finish the iteration, checkpoint, stop
                    self.stop = stop
                    return self._loop(learner, metrics, max(asi_version, info.version))
            finally:
                metrics.close()
                self.close()  # the workers stop before their ASI server does

    def _start_from(self, learner: PPOLearner, source: str) -> None:
        """`--start-from`: another run's (or checkpoint's) weights start this one; one line says which."""
        path = Path(source)
        if path.is_dir():
            from services.training.run_dir import run_checkpoint

            path = run_checkpoint(path, "best")
        elif not path.is_file():
            raise SfvError(f"--start-from {source}: no such run directory or checkpoint")
        dropped = learner.start_from(load_checkpoint(path)["learner"])
        log.info("started from %s%s", path, f" (its last {dropped} action numbers dropped)" if dropped else "")

    def _restore(self, learner: PPOLearner, checkpoint: dict) -> int:
        """Learner state and counters from a checkpoint; metrics rows after it are dropped. Returns its ASI version."""
        learner.load_state_dict(checkpoint["learner"])
        self.samples = int(checkpoint["samples"])
        self.iteration = int(checkpoint["iteration"])
        self.faults.failures = int(checkpoint.get("worker_failures", 0))
        self.faults.restarts = int(checkpoint.get("worker_restarts", 0))
        self.faults.ray_restarts = int(checkpoint.get("ray_restarts", 0))
        self.best_eval = checkpoint.get("best_eval")
        self.terrain_level = checkpoint.get("terrain_level")
        dropped = drop_metrics_after(self.run_dir, self.samples)
        if dropped:
            log.warning("%s: dropped %d metrics rows written after the checkpoint (iterations redone now)", self.run_dir, dropped)
        return int(checkpoint.get("asi_version", 0))

    def _terrain_start_level(self) -> int:
        """The level every env's terrain curriculum starts at: 0 on a fresh run, the checkpoint's
        mean level (rounded) on a resumed one, so a resume does not climb back from flat ground."""
        env = self.config.env
        if self.terrain_level is None or env.terrain is None or not env.terrain_curriculum:
            return 0
        level = min(max(int(round(self.terrain_level)), 0), TERRAIN_LEVELS)
        log.info("terrain curriculum: resuming at level %d (difficulty %.2f)", level, env.terrain_difficulty * level / TERRAIN_LEVELS)
        return level

    def _loop(self, learner: PPOLearner, metrics: MetricsLog, asi_version: int) -> dict:
        import sys

        from tqdm import tqdm

        from services.training.evaluation import TrainingEvaluator

        config = self.config
        steps = config.steps_per_worker
        bar = tqdm(total=config.samples, initial=min(self.samples, config.samples), unit="samples", disable=not self.progress, dynamic_ncols=True)
        record: dict = {}
        start_samples, start_time = self.samples, time.perf_counter()
        last_plot = start_time
        evaluator = TrainingEvaluator(config)  # strict, evenly phased episodes every eval_every samples and at the end
        while self.samples < config.samples:
            t0 = time.perf_counter()
            version = self.iteration
            results = self._collect(learner.policy_weights(), version, steps)
            batch = self._merge(results, version)
            t_sample = time.perf_counter() - t0
            coverage = self._select_tuples(batch)
            t_update = time.perf_counter()
            losses = self._update(learner, batch)
            batch["update_seconds"] = time.perf_counter() - t_update
            n = batch["rewards"].size
            samples_before = self.samples
            self.samples += n
            self.iteration += 1
            asi_version = max(asi_version, batch["asi_version"])
            losses.update(learner.set_progress(self.samples))  # for the next batch
            record = self._record(batch, losses, n, time.perf_counter() - t0, t_sample, asi_version)
            if self.asi_drift is not None:
                # The server's own version: an embedded server restarts its job at 0 on --resume,
                # below the checkpoint's, and the drift must still follow its updates.
                record.update(self.asi_drift(int(batch["asi_version"])))
            record.update(coverage)
            if evaluator.due(samples_before, self.samples, last=self.samples >= config.samples):
                try:  # the current weights on strict episodes; figures land in metrics.jsonl and TensorBoard
                    record.update(evaluator(learner.policy_weights(), self._residual_strength()))
                except Exception as exc:  # like the plot, an evaluation must never stop training
                    log.warning("evaluation at %d samples failed: %s: %s", self.samples, type(exc).__name__, exc)
                else:
                    self._keep_best(learner, record, asi_version)
                    line = evaluator.summary(self.samples, record)
                    if self.progress:
                        tqdm.write(line, file=sys.stderr)  # beside the bar; stdout ends with the JSON summary
                    else:
                        log.info("%s", line)
            metrics.write(record)
            bar.update(n)
            bar.set_postfix(sps=f"{record['samples_per_s']:.0f}", ret=_fmt(record["normalized_return"]), asi=asi_version)
            last = self.samples >= config.samples
            if self.iteration % config.checkpoint_every == 0 or last or self._stop_requested():
                self._checkpoint(learner, asi_version)
            if self._stop_requested() and not last:
                bar.close()
                self._stopped()
            if config.plot_every and (last or (self.iteration % config.plot_every == 0
                                               and time.perf_counter() - last_plot >= config.plot_min_interval_s)):
                self._plot()
                last_plot = time.perf_counter()
        bar.close()
        elapsed = time.perf_counter() - start_time
        record["overall_samples_per_s"] = (self.samples - start_samples) / max(elapsed, 1e-9)
        return record

    def _stop_requested(self) -> bool:
        return self.stop is not None and self.stop.requested is not None

    resume_command = "sfv train"  # the command whose --resume continues a stopped run (TaskTrainer: sfv task KIND)

    def _stopped(self) -> None:
        """After a stop signal's checkpoint: the curve drawn, then `TrainingStopped` saying how to go on."""
        if self.config.plot_every:
            self._plot()
        newest = latest_checkpoint(self.run_dir)
        raise TrainingStopped(f"{self.run_dir}: stopped by {self.stop.name} at {self.samples:,} samples, "
                              f"iteration {self.iteration}; checkpoint {newest.name if newest else 'none'} written "
                              f"({self.resume_command} --resume --out {self.run_dir} continues)", self.stop.requested)

    def _select_tuples(self, batch: dict) -> dict:
        """The tuples this update trains on (`--ppo.tuple-sampling`, paper 002 §5.2) and their
        coverage of the frames; the draw's seed follows from the run's seed and the iteration,
        so a resumed run draws as the uninterrupted one would."""
        ppo = self.config.ppo
        rng = np.random.default_rng([self.config.seed, self.iteration, 13])
        return select_tuples(batch, ppo.tuple_sampling, ppo.tuples_per_episode, rng, self.track_rows)

    def _update(self, learner: PPOLearner, batch: dict) -> dict:
        try:
            return learner.update(batch)  # raises NonFiniteError on NaN/inf, weights untouched
        except NonFiniteError as exc:
            newest = latest_checkpoint(self.run_dir)
            raise NonFiniteError(
                f"{self.run_dir}: iteration {self.iteration + 1} rejected, non-finite values ({exc}); training stopped, "
                f"nothing of it applied or checkpointed (newest checkpoint: {newest.name if newest else 'none'})") from None

    def _record(self, batch, losses, n, seconds, sample_seconds, asi_version) -> dict:
        episodes = batch["episode_normalized_returns"]
        mean = lambda a: float(np.mean(a)) if len(a) else None  # noqa: E731
        record = {
            "iteration": self.iteration,
            "samples": self.samples,
            "samples_per_s": n / seconds,
            "sampling_samples_per_s": n / max(sample_seconds, 1e-9),
            "learner_update_s": batch["update_seconds"],  # the PPO update alone (the learner's busy time)
            "normalized_return": mean(episodes),
            "episode_length": mean(batch["episode_lengths"]),
            "fall_rate": mean(batch["episode_fell"].astype(np.float32)),
            "episodes": int(len(episodes)),
            "reward_mean": float(batch["rewards"].mean()),
            "asi_version": int(asi_version),
            "charts/horizon_s": self._horizon_s() or self.config.env.horizon_s,
            **({"charts/terrain_difficulty": mean(batch["episode_terrain_difficulty"])} if "episode_terrain_difficulty" in batch else {}),
            "asi_dropped_reports": int(batch["asi_dropped_reports"]),
            "worker_failures": self.faults.failures,
            "worker_restarts": self.faults.restarts,
            "ray_restarts": self.faults.ray_restarts,
            "policy_version": batch["policy_versions"][0],
            "policy_lag": int(batch["policy_lag"]),
            "policy_lag_mean": batch["policy_lag_mean"],
            "stale_shares": self.collector.stale_shares if self.collector is not None else 0,
            "batch_policy_versions": batch["policy_versions"],
            "batch_worker_indices": batch["worker_indices"],
            "time": time.time(),
        }
        record.update({k if "/" in k else f"losses/{k}": float(v) for k, v in losses.items()})
        record.update(fall_cause_shares(batch.get("episode_fall_causes"), character_named(self.config.env.character)))
        return record

    def _keep_best(self, learner: PPOLearner, record: dict, asi_version: int) -> None:
        """Write `best.pt` when this evaluation beats every earlier one: returns peak and fall back
        (the cartwheel's in-training eval went .867 at 6.5 M to .72 at 8 M), so the policy to
        evaluate, render and export is the best one seen, not the newest."""
        score = record.get("eval/normalized_return")
        if not self._help_settled():
            return
        if score is None or not math.isfinite(score) or (self.best_eval is not None and score <= self.best_eval):
            return
        self.best_eval = float(score)
        record["eval/best_normalized_return"] = self.best_eval
        payload = self._payload(learner, asi_version)
        payload["eval"] = {k: v for k, v in record.items() if k.startswith("eval/") and isinstance(v, (int, float))}
        save_checkpoint(self.run_dir / BEST_CHECKPOINT, payload)

    def _payload(self, learner: PPOLearner, asi_version: int) -> dict:
        return {
            "learner": learner.state_dict(),
            "policy_weights": learner.policy_weights(),
            "samples": self.samples,
            "iteration": self.iteration,
            "asi_version": int(asi_version),
            "worker_failures": self.faults.failures,
            "worker_restarts": self.faults.restarts,
            "ray_restarts": self.faults.ray_restarts,
            "config": self.config.to_dict(),
            "best_eval": self.best_eval,
            "terrain_level": self.terrain_level,
            "residual_force_scale": self._residual_strength(),  # the help this policy was trained with (None: constant)
        }

    def _checkpoint(self, learner: PPOLearner, asi_version: int) -> None:
        save_checkpoint(checkpoint_path(self.run_dir, self.iteration), self._payload(learner, asi_version))
        old = sorted(self.run_dir.glob("checkpoint_*.pt"))[: -self.config.keep_checkpoints]
        for path in old:
            path.unlink(missing_ok=True)

    def _plot(self) -> None:
        try:
            from services.training.curves import plot_learning_curves

            plot_learning_curves([self.run_dir], self.run_dir / "learning_curve.png")
        except Exception as exc:  # a plot must never stop training
            log.warning("learning-curve plot failed: %s", exc)


class ASIDrift:
    """How far ASI's Gaussians have moved from where this process first saw them: after each new
    distribution version, `asi/mean_shift_sigma` (mean over components and dimensions of
    |mu - mu_0| / sigma_0) and `asi/std_ratio` (mean sigma / sigma_0); where starts go:
    `asi/weight_max` (largest component probability, 1/k when uniform) and `asi/fall_rate/<c>`.
    One RPC per new version."""

    def __init__(self, client):
        self.client = client
        self.version = -1
        self.first = None

    def __call__(self, version: int) -> dict:
        if self.client is None or version == self.version:
            return {}
        try:
            dist = self.client.get_distribution()
        except SfvError as exc:  # a figure for the log: never worth stopping training for
            log.warning("ASI distribution not read: %s", exc)
            return {}
        self.version = version
        if self.first is None:
            self.first = dist
        shift = np.abs(dist.means - self.first.means) / self.first.stds
        return {"asi/mean_shift_sigma": float(shift.mean()), "asi/std_ratio": float((dist.stds / self.first.stds).mean()),
                "asi/weight_max": float(dist.weights.max()),
                **{f"asi/fall_rate/{c}": float(rate) for c, rate in enumerate(dist.fall_rates)}}


def fall_cause_shares(causes: np.ndarray | None, character=HUMANOID3D) -> dict:
    """`falls/<link>`: the share of this batch's episodes that ended with that link on the
    ground (several links can touch at once); `falls/other`: ended otherwise (tracking
    deviation, divergence). Only the causes that occurred."""
    if causes is None or not len(causes):
        return {}
    names = [*character.link_names, "other"]
    bits = (np.asarray(causes, np.int64)[:, None] >> np.arange(len(names))) & 1
    shares = bits.mean(axis=0)
    return {f"falls/{name}": float(share) for name, share in zip(names, shares) if share > 0}


def _handover_states(config: TrainConfig) -> np.ndarray | None:
    """The `states` of --handover-states (a scene-fit window's starts), or None."""
    if config.handover_states is None:
        return None
    try:
        with np.load(config.handover_states) as f:
            return np.asarray(f["states"], np.float64)
    except (OSError, KeyError, ValueError) as exc:
        raise SfvError(f"{config.handover_states}: no hand-over states ({type(exc).__name__}: {exc})") from None


def _load_error(path: Path) -> str:
    try:
        load_checkpoint(path)
    except SfvError as exc:
        return str(exc)
    return "valid, but newer than the checkpoint resumed from"


def _fmt(value) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.3f}"


def check_learner_device(device: str) -> str:
    """The torch device `--device` names on this node: `auto` is the GPU when torch sees one,
    else the CPU; a device this node lacks is a one-line SfvError, not torch's traceback (a run
    trained on a GPU box and resumed on a CPU one keeps `device: cuda` in its config)."""
    import torch

    if device == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    try:
        kind = torch.device(device).type
    except (RuntimeError, ValueError) as exc:
        raise SfvError(f"--device {device}: not a torch device ({str(exc).splitlines()[0]})") from None
    if kind == "cuda" and not torch.cuda.is_available():
        raise SfvError(f"--device {device}: torch {torch.__version__} sees no CUDA device on this node; "
                       "--device cpu learns on the CPU (a resumed run takes it too)")
    return device


def _set_torch_threads(config: TrainConfig) -> int:
    import os

    import torch

    threads = config.torch_threads
    if threads <= 0:
        # Synchronous loop: sampling and learning take turns (workers block in sample() between
        # iterations), so the update may use every core of this node. Asynchronous loop: the
        # workers keep their cores while the learner updates, so it takes what they leave (>= 1).
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
        busy = config.workers if config.policy_lag > 0 else 0
        threads = max(1, cores - busy)
    torch.set_num_threads(threads)
    return threads
