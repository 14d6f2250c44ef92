"""Steps pybullet's own DeepMimic humanoid env on request; run as a script in its own process.

    python peer_probe.py --physics-hz 1200 --action-noise 0.1 --seed 0

It imports nothing from this project, so it can run under another interpreter (a venv
that holds pybullet + gym 0.26.2 + mpi4py). pybullet and DeepMimic print to stdout from C,
so the protocol uses a private copy of the original stdout and fd 1 goes to stderr.
Protocol, one JSON object a line: the probe first says {"ready": true, "shims": [...]} or
{"error": "..."}; then for every request {"seconds": S} it steps for at least S seconds
(random actions, reset when the episode ends) and answers {"steps", "seconds",
"cpu_seconds", "resets"}.
An empty line or EOF ends it.

Shims (only what pybullet_envs 3.2.7 needs under gym 0.26 / setuptools >= 81):
* `pkg_resources.parse_version`: deep_mimic_env imports it; setuptools 81 dropped
  pkg_resources, so `packaging.version.parse` stands in when the import fails.
* `registry.env_specs`: pybullet_envs/__init__ asks the gym < 0.26 registry object for it;
  gym 0.26's registry is a plain dict, so it is wrapped in a dict whose env_specs is itself.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import types


def install_shims() -> list[str]:
    shims = []
    try:
        import pkg_resources  # noqa: F401
    except ImportError:
        import packaging.version

        module = types.ModuleType("pkg_resources")
        module.parse_version = packaging.version.parse
        sys.modules["pkg_resources"] = module
        shims.append("pkg_resources.parse_version -> packaging.version.parse (setuptools without pkg_resources)")
    from gym.envs import registration

    if not hasattr(registration.registry, "env_specs"):
        class RegistryWithEnvSpecs(dict):
            @property
            def env_specs(self):
                return self

        registration.registry = RegistryWithEnvSpecs(registration.registry)
        shims.append("gym.envs.registration.registry.env_specs -> the registry dict (gym 0.26 API)")
    return shims


class PeerStepper:
    def __init__(self, physics_hz: float, action_noise: float, seed: int):
        import numpy as np
        from pybullet_envs.deep_mimic.gym_env.deep_mimic_env import HumanoidDeepBulletEnv

        self.np = np
        self.env = HumanoidDeepBulletEnv(arg_file="run_humanoid3d_walk_args.txt", time_step=1.0 / physics_hz)
        self.rng = np.random.default_rng(seed)
        self.action_noise = action_noise
        self.action_dim = self.env.action_space.shape[0]
        self.substeps = self.env._num_env_steps
        self.env.reset()

    def run_for(self, seconds: float) -> dict:
        env, np = self.env, self.np
        steps = resets = 0
        start, cpu_start = time.perf_counter(), time.process_time()
        while True:
            action = np.clip(self.rng.standard_normal(self.action_dim) * self.action_noise, -1.0, 1.0)
            _, _, done, _ = env.step(action)
            steps += 1
            if done:
                resets += 1
                env.reset()
            elapsed = time.perf_counter() - start
            if elapsed >= seconds:
                return {"steps": steps, "seconds": elapsed, "cpu_seconds": time.process_time() - cpu_start, "resets": resets}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--physics-hz", type=float, required=True)
    parser.add_argument("--action-noise", type=float, default=0.1)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    channel = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # everything else printed, from Python or C, goes to stderr
    sys.stdout = sys.stderr

    def say(obj: dict) -> None:
        channel.write(json.dumps(obj) + "\n")

    try:
        shims = install_shims()
        stepper = PeerStepper(args.physics_hz, args.action_noise, args.seed)
    except Exception as exc:  # the parent turns this into a skip message
        say({"error": f"{type(exc).__name__}: {exc}"})
        return 1
    import gym
    import pybullet

    say({"ready": True, "shims": shims, "substeps": stepper.substeps, "action_dim": stepper.action_dim,
         "gym": gym.__version__, "pybullet_api": pybullet.getAPIVersion()})
    for line in sys.stdin:
        if not line.strip():
            break
        say(stepper.run_for(float(json.loads(line)["seconds"])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
