"""Distil the dataset into the motor module (004 §3.3 eq. 4): training loop, checkpoints, module export.

The module directory (`--out MODULE`):
    config.json                the MotorModuleConfig, the dataset, the clips trained on and held out
    checkpoint_<update>.pt     resumable training state (learner/checkpoint.py; newest 2 kept)
    metrics.jsonl, tb/         one row per log interval: loss, nll, kl, rmse_rad, val/..., steps_per_s
    loss_curve.png             training and validation loss, KL and target RMSE against steps
    module.pt                  the final module (torch state dict + config), for the encoder
    decoder.npz, decoder.onnx  the decoder for rollouts without torch (learner/motor_decoder*.py)
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from learner.atomic_io import atomic_write_json
from learner.errors import SfvError
from learner.motor_config import MotorModuleConfig
from services.motor.dataset import load_dataset
from services.motor.sequences import WindowSampler

CONFIG_FILE = "config.json"
MODULE_FILE = "module.pt"
KEEP_CHECKPOINTS = 2
NORMALISER_ROWS = 200_000
VALIDATION_WINDOWS = 512


@dataclass
class DistillRun:
    updates: int
    log_every: int = 50
    checkpoint_every: int = 500
    device: str = "auto"
    torch_threads: int | None = None
    progress: bool = True


def pick_device(name: str):
    import torch

    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        return torch.device(name)
    except RuntimeError as exc:
        raise SfvError(f"distill: --device {name!r} is not a torch device ({exc})") from None


def _write_module_config(out: Path, config: MotorModuleConfig, dataset: Path, manifest: dict, held_out: tuple[str, ...]) -> None:
    path = out / CONFIG_FILE
    record = {"module": config.to_dict(), "dataset": str(dataset), "held_out": list(held_out),
              "clips": [c for c in manifest["clips"] if c not in held_out],
              "decoder_input": f"proprio ({config.proprio_dim}): actors/envs/tasks/proprioception.py; z (latent_dim)",
              "decoder_output": f"absolute PD targets ({config.action_dim}, rad), the env's ctrl order (actors/character/actions.py)",
              "encoder_input": f"future ({config.future_dim}): actors/envs/tasks/future_reference.py (k = 5) and z_t-1"}
    if path.exists():
        saved = json.loads(path.read_text())
        if saved.get("module") != json.loads(json.dumps(record["module"])) or saved.get("held_out") != record["held_out"]:
            raise SfvError(f"{path}: a module with other settings is there (resume takes the same settings, or pick another --out)")
        return
    atomic_write_json(path, record, sort_keys=True)


class Distiller:
    def __init__(self, dataset: Path, out: Path, config: MotorModuleConfig, held_out: tuple[str, ...], run: DistillRun):
        import torch

        from learner.motor_module import MotorModule

        if run.torch_threads:
            torch.set_num_threads(run.torch_threads)
        data, manifest = load_dataset(dataset, held_out)
        config = config.with_sizes_of(data["proprio"].shape[1], data["future"].shape[1], data["mean_targets"].shape[1])
        self.out, self.config, self.run = Path(out), config, run
        self.clips = [c for c in manifest["clips"] if c not in held_out]
        self.out.mkdir(parents=True, exist_ok=True)
        _write_module_config(self.out, config, Path(dataset), manifest, held_out)
        self.device = pick_device(run.device)
        self.sampler = WindowSampler(data["clip"], data["episode"], config.window, config.validation_fraction, config.seed)
        self.data = {name: torch.from_numpy(np.ascontiguousarray(data[name])).to(self.device)
                     for name in ("proprio", "future", "mean_targets")}
        self.steps_total = len(data["clip"])
        generator = torch.Generator().manual_seed(config.seed)
        self.module = MotorModule(config, generator)
        rows = np.random.default_rng(config.seed).permutation(len(data["clip"]))[:NORMALISER_ROWS]
        self.module.set_normalisation(data["proprio"][rows], data["future"][rows], data["mean_targets"][rows])
        self.module.to(self.device)
        self.optimizer = torch.optim.Adam(self.module.parameters(), lr=config.lr)
        self.noise = torch.Generator(device=self.device).manual_seed(config.seed + 1)
        self.rng = np.random.default_rng(config.seed + 2)
        validation = self.sampler.validation_starts
        self.validation_rows = self.sampler.rows(np.random.default_rng(config.seed + 3).permutation(validation)[:VALIDATION_WINDOWS]) if len(validation) else None
        self.update, self.samples = 0, 0

    # ------------------------------------------------------------------ state
    def state(self) -> dict:
        return {"module": self.module.state_dict(), "optimizer": self.optimizer.state_dict(), "update": self.update,
                "samples": self.samples, "config": self.config.to_dict(), "noise": self.noise.get_state(),
                "rng": json.dumps(self.rng.bit_generator.state), "clips": self.clips}

    def resume(self) -> bool:
        """Continue from the newest good checkpoint in the module directory; False when none."""
        from learner.checkpoint import latest_checkpoint, load_checkpoint
        from services.training.run_dir import drop_metrics_after

        path = latest_checkpoint(self.out)
        if path is None:
            return False
        state = load_checkpoint(path)
        if MotorModuleConfig.from_dict(state.get("config", {})) != self.config:
            raise SfvError(f"{path}: saved with other module settings; resume with the same ones")
        self.module.load_state_dict(state["module"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.update, self.samples = int(state["update"]), int(state["samples"])
        self.noise.set_state(state["noise"])
        self.rng.bit_generator.state = json.loads(state["rng"])
        drop_metrics_after(self.out, self.samples)
        return True

    def checkpoint(self) -> None:
        from learner.checkpoint import checkpoint_path, save_checkpoint
        from services.training.run_dir import checkpoint_files

        save_checkpoint(checkpoint_path(self.out, self.update), self.state())
        for old in checkpoint_files(self.out)[:-KEEP_CHECKPOINTS]:
            old.unlink(missing_ok=True)

    # ---------------------------------------------------------------- training
    def _batch(self, rows: np.ndarray):
        import torch

        index = torch.from_numpy(rows).to(self.device)
        return self.data["proprio"][index], self.data["future"][index], self.data["mean_targets"][index]

    def step(self) -> dict[str, float]:
        import torch

        c = self.config
        terms = self.module.sequence_loss(*self._batch(self.sampler.sample(self.rng, c.batch_windows)), self.noise)
        self.optimizer.zero_grad(set_to_none=True)
        terms["loss"].backward()
        torch.nn.utils.clip_grad_norm_(self.module.parameters(), c.max_grad_norm)
        self.optimizer.step()
        self.update += 1
        self.samples += c.batch_windows * c.window
        return {key: float(value.detach()) for key, value in terms.items()}

    def validate(self) -> dict[str, float]:
        import torch

        if self.validation_rows is None:
            return {}
        with torch.no_grad():
            terms = self.module.sequence_loss(*self._batch(self.validation_rows), sample=False)
        return {f"val/{key}": float(value) for key, value in terms.items()}

    def train(self) -> None:
        from tqdm import tqdm

        from services.motor.curves import plot_loss_curve
        from services.training.run_dir import MetricsLog

        resumed = self.resume()
        log = MetricsLog(self.out, self.samples if resumed else None)
        bar = tqdm(total=self.run.updates, initial=min(self.update, self.run.updates), unit="update", desc="distill", disable=not self.run.progress)
        sums: dict[str, float] = {}
        count, started = 0, time.perf_counter()
        try:
            while self.update < self.run.updates:
                for key, value in self.step().items():
                    sums[key] = sums.get(key, 0.0) + value
                count += 1
                bar.update()
                if self.update % self.run.log_every == 0 or self.update == self.run.updates:
                    elapsed = time.perf_counter() - started
                    row = {key: value / count for key, value in sums.items()} | self.validate()
                    row |= {"samples": self.samples, "update": self.update, "steps_per_s": count * self.config.batch_windows * self.config.window / elapsed,
                            "action_std_rad": float(self.module.action_std().mean().detach())}
                    log.write(row)
                    bar.set_postfix(loss=f"{row['loss']:.2f}", kl=f"{row['kl']:.1f}", rmse=f"{row['rmse']:.3f}")
                    sums, count, started = {}, 0, time.perf_counter()
                if self.update % self.run.checkpoint_every == 0:
                    self.checkpoint()
                    plot_loss_curve(self.out)
        finally:
            bar.close()
            log.close()
        self.checkpoint()
        plot_loss_curve(self.out)
        export_module(self.out, self.module)
        record_latent_range(self.out, self.latent_range())

    def latent_range(self, windows: int = 1024) -> dict:
        """Where the encoder puts z on the training data: its posterior means over `windows`
        sequences (z_t-1 chained through each window, as in training), per component. A task
        policy's action box (`--latent-scale`) should cover this range and not much more:
        beyond it the decoder was never trained."""
        import torch

        starts = np.random.default_rng(self.config.seed + 4).choice(self.sampler.train_starts, size=windows)
        _, future, _ = self._batch(self.sampler.rows(starts))
        with torch.no_grad():
            z_prev = future.new_zeros(windows, self.config.latent_dim)
            means = []
            for t in range(future.shape[1]):
                z_prev, _ = self.module.encode(future[:, t], z_prev)
                means.append(z_prev)
        mu = torch.stack(means, dim=1).reshape(-1, self.config.latent_dim).cpu().numpy()
        absolute = np.abs(mu)
        return {"windows": int(windows), "prior_std": self.config.prior_std,
                "abs_p50": float(np.percentile(absolute, 50)), "abs_p95": float(np.percentile(absolute, 95)),
                "abs_p99": float(np.percentile(absolute, 99)), "std_per_component": mu.std(axis=0).round(4).tolist(),
                "components_used": int((mu.std(axis=0) > 0.1 * self.config.prior_std).sum()),
                "principal": principal_directions(mu)}


def export_module(out: Path, module) -> None:
    """module.pt (torch), decoder.npz and decoder.onnx into the module directory."""
    from learner.checkpoint import save_checkpoint
    from learner.motor_decoder import DECODER_NPZ, save_decoder_npz
    from learner.motor_decoder_onnx import export_decoder_onnx

    module = module.cpu()
    save_checkpoint(out / MODULE_FILE, {"module": module.state_dict(), "config": module.config.to_dict()})
    weights = module.decoder_weights()
    save_decoder_npz(weights, out / DECODER_NPZ)
    export_decoder_onnx(weights, out / "decoder.onnx")


PRINCIPAL_KEPT = 16


def principal_directions(mu: np.ndarray, kept: int = PRINCIPAL_KEPT) -> dict:
    """The posterior means' centre and their `kept` principal directions (unit rows, largest
    first) with the std along each and the cumulative share of variance: the subspace a task
    policy can move z in (`TaskEnvConfig.latent_directions`). On the shipped module 2 directions
    hold 61 % of the variance, 8 hold 92 %, and the centre is 1.9 from z = 0."""
    centre = mu.mean(axis=0)
    _, singular, rows = np.linalg.svd(mu - centre, full_matrices=False)
    variance = singular ** 2 / max(len(mu) - 1, 1)
    kept = min(kept, len(variance))
    return {"mean": centre.round(5).tolist(), "directions": rows[:kept].round(5).tolist(),
            "std": np.sqrt(variance[:kept]).round(5).tolist(),
            "cumulative_variance": (np.cumsum(variance) / variance.sum())[:kept].round(4).tolist()}


def record_latent_range(out: Path, latent_range: dict) -> None:
    """Add the encoder's latent range to the module's config.json (`Distiller.latent_range`)."""
    path = Path(out) / CONFIG_FILE
    record = json.loads(path.read_text())
    record["latent_range"] = latent_range
    atomic_write_json(path, record, sort_keys=True)


def load_module(directory: Path):
    """The torch MotorModule of a module directory (module.pt), in eval mode on the CPU."""
    from learner.checkpoint import load_checkpoint
    from learner.motor_module import MotorModule

    path = Path(directory) / MODULE_FILE
    state = load_checkpoint(path)
    try:
        module = MotorModule(MotorModuleConfig.from_dict(state["config"]))
        module.load_state_dict(state["module"])
    except (KeyError, RuntimeError) as exc:
        raise SfvError(f"{path}: not a motor module ({type(exc).__name__}: {str(exc)[:200]})") from None
    return module.eval()
