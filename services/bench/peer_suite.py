"""Suite `peer`: this project's env against pybullet's own DeepMimic humanoid env.

Both step one env in one process with random actions (N(0, noise^2) in each env's
normalised action space, clipped), observation and reward computed, reset when the
episode ends, at the same physics rates: pybullet DeepMimic's default 240 Hz and the
paper's 1.2 kHz, policy at 30 Hz in both. The peer runs in a child process
(`peer_probe.py`, optionally under another interpreter) so that gym 0.26 and the shims it
needs never touch this process; the two are still interleaved in every repetition.
"""
from __future__ import annotations

import json
import select
import subprocess
import sys
import tempfile
from pathlib import Path

from actors.motion.formats.io import load_motion
from services.bench.config import TARGET_OURS_OVER_PEER_1200HZ, BenchConfig
from services.bench.env_suite import add_ratio_pair, env_config_for, step_summaries
from services.bench.measure import Rates, interleaved, rate_for
from services.bench.result import SuiteResult
from services.bench.steppers import EnvStepper

# Run as a script (under another interpreter when given), never imported here: it installs gym shims.
PEER_PROBE = Path(__file__).with_name("peer_probe.py")

START_TIMEOUT_S = 120.0


class PeerUnavailable(RuntimeError):
    """The peer process could not start its env (missing packages, import errors)."""


class PeerProcess:
    """A running `peer_probe.py`; `rate(seconds)` asks it for one timed measurement."""

    def __init__(self, python: str, physics_hz: float, action_noise: float, seed: int):
        self._stderr = tempfile.TemporaryFile()
        command = [python, str(PEER_PROBE), "--physics-hz", repr(physics_hz),
                   "--action-noise", repr(action_noise), "--seed", str(seed)]
        self.proc = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._stderr, text=True)
        hello = self._read(START_TIMEOUT_S)
        if "error" in hello:
            self.close()
            raise PeerUnavailable(hello["error"])
        self.info = hello
        self.resets = 0

    def _read(self, timeout: float) -> dict:
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        line = self.proc.stdout.readline() if ready else ""
        if not line:
            try:
                status = f"exit code {self.proc.wait(timeout=5)}"
            except subprocess.TimeoutExpired:
                status = f"no answer within {timeout:g} s"
            message = f"peer process failed ({status}): {self.stderr_tail()}"
            self.close()
            raise PeerUnavailable(message)
        return json.loads(line)

    def rate(self, seconds: float) -> Rates:
        self.proc.stdin.write(json.dumps({"seconds": seconds}) + "\n")
        self.proc.stdin.flush()
        answer = self._read(max(60.0, 20 * seconds))
        self.resets += answer["resets"]
        return Rates(answer["steps"] / answer["seconds"], answer["steps"] / max(answer["cpu_seconds"], 1e-9))

    def stderr_tail(self, lines: int = 3) -> str:
        self._stderr.seek(0)
        text = self._stderr.read().decode(errors="replace").strip().splitlines()
        return " | ".join(text[-lines:]) or "(no output)"

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.proc.stdin.write("\n")
                self.proc.stdin.flush()
                self.proc.wait(timeout=10)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()
        if not self._stderr.closed:
            self._stderr.close()


def rate_label(hz: float) -> str:
    return f"{hz:g}hz"


def run_peer_suite(config: BenchConfig, log) -> SuiteResult:
    python = config.peer_python or sys.executable
    settings = {"peer_python": python, "physics_rates_hz": list(config.peer_rates), "control_hz": 30.0,
                "repeats": config.repeats, "seconds_per_measurement": config.seconds, "action_noise": config.action_noise,
                "peer_env": "pybullet_envs.deep_mimic.gym_env.deep_mimic_env.HumanoidDeepBulletEnv(arg_file='run_humanoid3d_walk_args.txt')",
                "ours_env": f"actors.envs.imitation_env.ImitationEnv({config.motion})"}
    peers: list[PeerProcess] = []
    try:
        for hz in config.peer_rates:
            peers.append(PeerProcess(python, hz, config.action_noise, config.seed))
    except PeerUnavailable as exc:
        for peer in peers:
            peer.close()
        return SuiteResult.skip("peer", f"pybullet's DeepMimic env is not usable with {python} ({exc}); "
                                        "install the `peer` extra: pip install 'sfv[peer]'", **settings)
    try:
        motion = load_motion(config.motion)
        variants, ours_by_rate = {}, {}
        for hz, peer in zip(config.peer_rates, peers):
            ours = EnvStepper(motion, env_config_for(hz), config.action_noise, config.seed)
            if ours.env.substeps != peer.info["substeps"]:
                raise RuntimeError(f"substeps differ at {hz} Hz: ours {ours.env.substeps}, peer {peer.info['substeps']}")
            label = rate_label(hz)
            variants[f"peer_{label}"] = lambda p=peer, label=label: p.rate(config.seconds).named(f"peer_{label}_steps")
            variants[f"ours_{label}"] = lambda o=ours, label=label: rate_for(config.seconds, o.chunk).named(f"ours_{label}_steps")
            ours_by_rate[hz] = ours
        runs = interleaved(variants, config.repeats, on_result=lambda r, n, v: log(f"  rep {r + 1}: {n} = {v:,.1f}"))
    finally:
        for peer in peers:
            peer.close()
    result = SuiteResult("peer", step_summaries(runs), settings={**settings, "peer_shims": peers[0].info["shims"],
                                                    "peer_gym": peers[0].info["gym"]})
    for hz, peer in zip(config.peer_rates, peers):
        label = rate_label(hz)
        target = TARGET_OURS_OVER_PEER_1200HZ if hz == 1200.0 else None
        add_ratio_pair(result, f"ours_over_peer_{label}", f"ours_{label}_steps", f"peer_{label}_steps", target=target)
        result.notes.append(f"{label}: {peer.info['substeps']} substeps per control step; episodes ended: "
                            f"peer {peer.resets}, ours {ours_by_rate[hz].resets}")
    return result
