"""The training driver: rollout workers -> PPO learner -> weights -> workers, ASI alongside.

Roles follow RLlib's new stack / sample-factory: `RolloutWorker`s (actors/) only sample,
`PPOLearner` (learner/) only updates, and this driver moves weights out through the Ray
object store and trajectories back as numpy arrays. `serial=True` runs the same workers in
this process without Ray (debugging, CI, machines without Ray).

Faults: a worker that dies is restarted by Ray (`max_restarts=-1`); its share of the batch
is handed to a worker that is alive, so an iteration never waits on a dead process. Every
batch is checked to come from the current policy version. A non-finite observation, reward
or gradient stops training with a message, before any checkpoint could be poisoned.
"""
from __future__ import annotations

import hashlib
import logging
import math
import time
from pathlib import Path

import numpy as np

from actors.errors import SfvError
from actors.features import OBS_DIM
from actors.imitation_env import ImitationEnv
from actors.motion_io import load_motion
from actors.rollout_worker import RolloutWorker, WorkerSpec
from learner.checkpoint import checkpoint_path, latest_checkpoint, load_checkpoint, save_checkpoint
from learner.ppo import PPOLearner
from services.asi_setup import ASIConnection
from services.run_dir import CONFIG_FILE, MetricsLog, write_json_atomic
from services.train_config import TrainConfig

log = logging.getLogger("sfv.train")
TRAJECTORY_KEYS = ("obs", "next_obs", "actions", "logp", "rewards", "terminated", "truncated")


def default_job_id(config: TrainConfig) -> str:
    digest = hashlib.sha1(str(Path(config.out).resolve()).encode()).hexdigest()[:10]
    return f"{Path(config.out).name or 'run'}-{digest}"


class Trainer:
    def __init__(self, config: TrainConfig, resume: bool = False, progress: bool = True):
        config.validate()
        self.config = config
        self.resume = resume
        self.progress = progress
        self.run_dir = Path(config.out)
        self.worker_failures = 0
        self.samples = 0
        self.iteration = 0

    # ------------------------------------------------------------------ setup
    def _prepare_run_dir(self) -> dict | None:
        self.run_dir.mkdir(parents=True, exist_ok=True)
        latest = latest_checkpoint(self.run_dir)
        if latest is not None and not self.resume:
            raise SfvError(f"{self.run_dir}: holds checkpoints already; pass --resume to continue or choose another --out")
        if self.resume and latest is None:
            raise SfvError(f"{self.run_dir}: --resume given but there is no checkpoint to resume from")
        if self.config.job_id is None:
            self.config.job_id = default_job_id(self.config)
        write_json_atomic(self.run_dir / CONFIG_FILE, self.config.to_dict())
        return load_checkpoint(latest) if latest is not None else None

    def _reference_table(self, motion):
        env = ImitationEnv(motion, self.config.env)
        rows = np.arange(env.track.start_steps)
        states = np.stack([env.reference_state_vector(r) for r in rows])
        return env, states, env.track.phase[rows]

    def _make_workers(self, spec: WorkerSpec):
        n = self.config.workers
        if self.config.serial:
            return [RolloutWorker(spec, i) for i in range(n)]
        import ray

        remote_cls = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=0)(RolloutWorker)
        workers = [remote_cls.remote(spec, i) for i in range(n)]
        ray.get([w.ping.remote() for w in workers])  # construction errors surface here
        return workers

    def _init_ray(self):
        if self.config.serial:
            return
        import ray

        if ray.is_initialized():
            return
        if self.config.ray_address:
            ray.init(address=self.config.ray_address, log_to_driver=True)
        else:
            ray.init(num_cpus=max(self.config.workers, 1), include_dashboard=False, log_to_driver=True, configure_logging=False)

    # ------------------------------------------------------------- collection
    def _collect(self, workers, weights, version: int, steps: int) -> list[dict]:
        if self.config.serial:
            return [w.sample(weights, version, steps) for w in workers]
        import ray
        from ray.exceptions import GetTimeoutError, RayActorError, RayTaskError

        weights_ref = ray.put(weights)
        pending = {w.sample.remote(weights_ref, version, steps): i for i, w in enumerate(workers)}
        results, alive = [], set()
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=self.config.worker_timeout_s)
            if not ready:
                # A worker hangs: give every outstanding share to a worker that has answered.
                stuck = list(pending)
                for ref in stuck:
                    ray.cancel(ref, force=True)
                    index = pending.pop(ref)
                    self.worker_failures += 1
                    log.warning("worker %d timed out; its share goes to another worker", index)
                    target = min(alive) if alive else index
                    pending[workers[target].sample.remote(weights_ref, version, steps)] = target
                continue
            for ref in ready:
                index = pending.pop(ref)
                try:
                    results.append(ray.get(ref))
                    alive.add(index)
                except (RayActorError, RayTaskError, GetTimeoutError) as exc:
                    self.worker_failures += 1
                    target = min(alive) if alive else index  # a live worker, else the restarted one
                    log.warning("worker %d failed (%s); its share goes to worker %d", index, type(exc).__name__, target)
                    pending[workers[target].sample.remote(weights_ref, version, steps)] = target
        return results

    @staticmethod
    def _merge(results: list[dict], version: int) -> dict:
        versions = {int(r["policy_version"]) for r in results}
        if versions != {version}:
            raise SfvError(f"internal: a batch mixes policy versions {sorted(versions)} (expected {version})")
        batch = {k: np.concatenate([r[k] for r in results], axis=1) for k in TRAJECTORY_KEYS}
        for k in results[0]:
            if k.startswith("episode_"):
                batch[k] = np.concatenate([r[k] for r in results])
        batch["asi_version"] = max(int(r["asi_version"]) for r in results)
        batch["asi_dropped_reports"] = sum(int(r["asi_dropped_reports"]) for r in results)
        return batch

    # -------------------------------------------------------------------- run
    def run(self) -> dict:
        config = self.config
        checkpoint = self._prepare_run_dir()
        motion = load_motion(config.motion)
        env, ref_states, ref_phases = self._reference_table(motion)
        learner = PPOLearner(OBS_DIM, env.action_space.shape[0], config.ppo, device=config.device)
        asi_version = 0
        if checkpoint is not None:
            learner.load_state_dict(checkpoint["learner"])
            self.samples = int(checkpoint["samples"])
            self.iteration = int(checkpoint["iteration"])
            self.worker_failures = int(checkpoint.get("worker_failures", 0))
            asi_version = int(checkpoint.get("asi_version", 0))
        self._init_ray()
        with ASIConnection(config) as asi:
            info = asi.create_job(ref_states, ref_phases)
            spec = WorkerSpec(motion, config.env, config.envs_per_worker, config.init, config.seed, config.ppo.gamma,
                              asi.address, config.job_id, asi.token)
            workers = self._make_workers(spec)
            metrics = MetricsLog(self.run_dir)
            try:
                return self._loop(learner, workers, metrics, max(asi_version, info.version))
            finally:
                metrics.close()

    def _loop(self, learner: PPOLearner, workers, metrics: MetricsLog, asi_version: int) -> dict:
        from tqdm import tqdm

        config = self.config
        steps = config.steps_per_worker
        bar = tqdm(total=config.samples, initial=min(self.samples, config.samples), unit="samples", disable=not self.progress, dynamic_ncols=True)
        record: dict = {}
        start_samples, start_time = self.samples, time.perf_counter()
        while self.samples < config.samples:
            t0 = time.perf_counter()
            version = self.iteration
            results = self._collect(workers, learner.policy_weights(), version, steps)
            batch = self._merge(results, version)
            t_sample = time.perf_counter() - t0
            losses = learner.update(batch)  # raises NonFiniteError on NaN/inf, weights untouched
            n = batch["rewards"].size
            self.samples += n
            self.iteration += 1
            asi_version = max(asi_version, batch["asi_version"])
            record = self._record(batch, losses, n, time.perf_counter() - t0, t_sample, asi_version)
            metrics.write(record)
            bar.update(n)
            bar.set_postfix(sps=f"{record['samples_per_s']:.0f}", ret=_fmt(record["normalized_return"]), asi=asi_version)
            if self.iteration % config.checkpoint_every == 0 or self.samples >= config.samples:
                self._checkpoint(learner, asi_version)
            if config.plot_every and (self.iteration % config.plot_every == 0 or self.samples >= config.samples):
                self._plot()
        bar.close()
        elapsed = time.perf_counter() - start_time
        record["overall_samples_per_s"] = (self.samples - start_samples) / max(elapsed, 1e-9)
        return record

    def _record(self, batch, losses, n, seconds, sample_seconds, asi_version) -> dict:
        episodes = batch["episode_normalized_returns"]
        mean = lambda a: float(np.mean(a)) if len(a) else None  # noqa: E731
        record = {
            "iteration": self.iteration,
            "samples": self.samples,
            "samples_per_s": n / seconds,
            "sampling_samples_per_s": n / max(sample_seconds, 1e-9),
            "normalized_return": mean(episodes),
            "episode_length": mean(batch["episode_lengths"]),
            "fall_rate": mean(batch["episode_fell"].astype(np.float32)),
            "episodes": int(len(episodes)),
            "reward_mean": float(batch["rewards"].mean()),
            "asi_version": int(asi_version),
            "asi_dropped_reports": int(batch["asi_dropped_reports"]),
            "worker_failures": self.worker_failures,
            "time": time.time(),
        }
        record.update({k if "/" in k else f"losses/{k}": float(v) for k, v in losses.items()})
        return record

    def _checkpoint(self, learner: PPOLearner, asi_version: int) -> None:
        payload = {
            "learner": learner.state_dict(),
            "policy_weights": learner.policy_weights(),
            "samples": self.samples,
            "iteration": self.iteration,
            "asi_version": int(asi_version),
            "worker_failures": self.worker_failures,
            "config": self.config.to_dict(),
        }
        save_checkpoint(checkpoint_path(self.run_dir, self.iteration), payload)
        old = sorted(self.run_dir.glob("checkpoint_*.pt"))[: -self.config.keep_checkpoints]
        for path in old:
            path.unlink(missing_ok=True)

    def _plot(self) -> None:
        try:
            from services.plotting import plot_learning_curves

            plot_learning_curves([self.run_dir], self.run_dir / "learning_curve.png")
        except Exception as exc:  # a plot must never stop training
            log.warning("learning-curve plot failed: %s", exc)


def _fmt(value) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.3f}"
