"""Training a task policy (NPMP 004 §3.4) with the imitation driver's machinery.

`TaskTrainer` is `services/training/driver.Trainer` with task workers: the same loop
(collect through a runner, PPO update, metrics.jsonl + TensorBoard, checkpoints, --resume),
the same runners (Ray actors, in-process, processes) and learner. What it replaces is the
imitation setup (motion, reference table, ASI server) and it adds the task figures to each
metrics row. Deviation from 004: PPO with an MLP policy instead of MPO/V-trace with an LSTM
(the paper: "the exact details are not critical for the results obtained").
"""
from __future__ import annotations

import numpy as np

from actors.rollout.task_worker import TaskRolloutWorker, TaskWorkerSpec
from actors.envs.tasks.vector_task_env import VectorTaskEnv
from learner.ppo import PPOLearner
from services.tasks.config import TaskConfig
from services.training.driver import Trainer, _set_torch_threads, check_learner_device
from services.training.run_dir import MetricsLog
from services.training.runners import make_runner
from services.training.stop_signals import StopSignals


def task_figures(batch: dict) -> dict:
    """Success rate, seconds to the first target and targets per episode of a batch's finished episodes."""
    successes = batch["episode_successes"]
    times = batch["episode_first_success_s"]
    reached = times[np.isfinite(times)]
    return {
        "success_rate": float(np.mean(successes)) if len(successes) else None,
        "time_to_target_s": float(np.mean(reached)) if len(reached) else None,
        "targets_per_episode": float(np.mean(batch["episode_targets_reached"])) if len(successes) else None,
        **_phase_figures(batch),
    }


def _phase_figures(batch: dict) -> dict:
    """The phased push-box's training figure: the share of the episodes started in its first phase
    that reached the box (other tasks log their start phase as -1 and get none)."""
    goto = np.asarray(batch.get("episode_start_phase", [])) == 0
    if not goto.any():
        return {}
    return {"box_reached_rate": float(np.mean(np.asarray(batch["episode_first_phase_done"])[goto]))}


class TaskTrainer(Trainer):
    worker_class = TaskRolloutWorker

    @property
    def resume_command(self) -> str:
        return f"sfv task {self.config.env.task.replace('_', '-')}"

    def __init__(self, config: TaskConfig, resume: bool = False, progress: bool = True):
        super().__init__(config, resume=resume, progress=progress)

    def run(self) -> dict:
        config = self.config
        probe = VectorTaskEnv(config.env, 1)  # the dims; a bad --module fails here, before anything is written
        self.track_rows = probe.max_episode_steps  # a task's frames are steps since the episode began
        checkpoint = self._prepare_run_dir()
        device = check_learner_device(config.device)
        _set_torch_threads(config)
        learner = PPOLearner(probe.obs_dim, probe.action_dim, config.ppo, device=device)
        del probe
        if checkpoint is not None:
            self._restore(learner, checkpoint)
        spec = TaskWorkerSpec(config.env, config.envs_per_worker, config.seed, config.ppo.gamma)
        self.runner = make_runner(config, self.worker_class, self.faults)
        self.runner.start(spec)
        metrics = MetricsLog(self.run_dir, resumed_at_samples=self.samples if checkpoint is not None else None)
        try:
            with StopSignals() as stop:  # SIGTERM / SIGINT: finish the iteration, checkpoint, stop
                self.stop = stop
                return self._loop(learner, metrics, 0)
        finally:
            metrics.close()
            self.close()

    def _record(self, batch, losses, n, seconds, sample_seconds, asi_version) -> dict:
        record = super()._record(batch, losses, n, seconds, sample_seconds, asi_version)
        record.update(task_figures(batch))
        return record
