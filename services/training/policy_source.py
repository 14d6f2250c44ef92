"""Where a rendered or exported rollout gets its policy and environment from.

Either a run directory's newest checkpoint (needs torch to read it), or an exported ONNX
file (onnxruntime only: torch is never imported on that path). The environment settings
come from the run's config.json when a run is given (its character among them), else the
defaults with `--motion`.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from actors.character.characters import character_named
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.character_reference import load_reference
from actors.motion.reference_motion import ReferenceMotion
from learner.errors import SfvError
from services.training.run_dir import load_run, read_run_config


@dataclass
class PolicySource:
    policy: object  # NumpyPolicy or OnnxPolicy: act(obs (1, obs_dim), deterministic=True)
    env_config: EnvConfig
    motion: str
    description: str  # what the policy was loaded from, for captions and reports
    checkpoint: str | None = None  # the run's checkpoint file it was read from (best.pt, checkpoint_N.pt); None for ONNX

    def reference(self) -> ReferenceMotion:
        """The motion in the pose space of the run's character (a humanoid clip retargeted for a robot)."""
        return load_reference(self.motion, character_named(self.env_config.character))

    def make_env(self) -> ImitationEnv:
        return ImitationEnv(self.reference(), self.env_config)


def load_policy_source(run_dir: str | Path | None, onnx: str | Path | None = None, motion: str | None = None,
                       checkpoint: str = "best") -> PolicySource:
    """Policy and env for a run directory (its best checkpoint, or `checkpoint="latest"`), an
    ONNX file, or both (ONNX policy, run's env)."""
    if run_dir is None and onnx is None:
        raise SfvError("give a run directory or --onnx FILE")
    if onnx is not None:
        from learner.onnx_export import OnnxPolicy

        if run_dir is not None:
            config = read_run_config(run_dir)
            env_config, motion_name = config.env, motion or config.motion
        elif motion is None:
            raise SfvError(f"{onnx}: an ONNX policy without a run directory needs --motion")
        else:
            env_config, motion_name = EnvConfig(), motion
        policy = OnnxPolicy(onnx, num_threads=1)  # one observation per call: threads only add overhead
        description = Path(onnx).name
    else:
        from learner.policy import NumpyPolicy
        from services.training.run_dir import run_checkpoint

        config, weights = load_run(run_dir, checkpoint)
        env_config, motion_name = config.env, motion or config.motion
        policy = NumpyPolicy(weights, max_batch=1)
        description = Path(run_dir).name
        return PolicySource(policy, env_config, motion_name, description, run_checkpoint(run_dir, checkpoint).name)
    return PolicySource(policy, env_config, motion_name, description)
