"""ASI starts spread over their component's phase bin: the state's deviation from the reference
is carried to the drawn phase, and the episode log keeps the state as drawn."""
from __future__ import annotations

import numpy as np
import pytest

from actors.character import quaternion as qn
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.initial_states import BufferedStarts, InitialStates
from actors.envs.vector_env import VectorImitationEnv
from actors.motion.formats.io import load_motion


@pytest.fixture(scope="module")
def backflip():
    return load_motion("deepmimic:backflip")


def _reference_state(env, row):
    return env.layout.state_vector(env.track.qpos[row], env.track.qvel[row])


def test_reference_state_at_one_phase_becomes_the_reference_at_another(backflip):
    env = ImitationEnv(backflip, EnvConfig())
    anchor, start = env.track.start_index(0.3), env.track.start_index(0.37)
    assert anchor != start
    env.reset(options={"phase": 0.37, "state": _reference_state(env, anchor), "state_phase": 0.3})
    np.testing.assert_allclose(env.data.qvel, env.track.qvel[start], atol=1e-9)
    np.testing.assert_allclose(env.data.qpos[:3], env.track.qpos[start, :3], atol=1e-9)
    angle = qn.quat_angle(qn.quat_mul(qn.quat_conj(env.track.qpos[start, 3:7]), env.data.qpos[3:7]))
    assert angle < 1e-6, "the root's orientation is the reference's at the drawn phase"


def test_a_perturbation_keeps_its_local_offset_at_the_new_phase(backflip):
    env = ImitationEnv(backflip, EnvConfig())
    anchor, start = env.track.start_index(0.5), env.track.start_index(0.58)
    state = _reference_state(env, anchor)
    state[0] += 0.05  # root 5 cm higher
    state[1:4] = qn.quat_to_axis_angle(qn.quat_mul(qn.quat_from_axis_angle(state[1:4]), qn.quat_about_axis(np.array(0.2), np.array([0.0, 0.0, 1.0]))))
    state[-1] += 0.7  # the last joint velocity
    env.reset(options={"phase": 0.58, "state": state, "state_phase": 0.5})
    assert env.data.qpos[2] == pytest.approx(env.track.qpos[start, 2] + 0.05, abs=1e-9)
    local = qn.quat_mul(qn.quat_conj(env.track.qpos[start, 3:7]), env.data.qpos[3:7])
    assert qn.quat_angle(local) == pytest.approx(0.2, abs=1e-6)  # the same 0.2 rad twist in the root's own frame
    assert env.data.qvel[-1] == pytest.approx(env.track.qvel[start, -1] + 0.7, abs=1e-9)


class _ComponentStarts:
    """The ASI server's shape of start: k fixed phases, a state drawn about each."""

    def __init__(self, states_by_phase):
        self.states_by_phase = states_by_phase
        self.phases = sorted(states_by_phase)

    def __call__(self, count):
        components = np.arange(count) % len(self.phases)
        phases = np.array([self.phases[c] for c in components])
        return InitialStates(phases, components, np.stack([self.states_by_phase[p] for p in phases]))


def _vector_env(backflip, spread):
    probe = ImitationEnv(backflip, EnvConfig())
    draws = {p: _reference_state(probe, probe.track.start_index(p)) + 0.01 for p in (0.0, 0.5)}
    source = _ComponentStarts(draws)
    return VectorImitationEnv(backflip, EnvConfig(horizon_s=0.2), 4, BufferedStarts(source, batch=8), seed=3,
                              start_phase_spread=spread), draws


def _start_rows(venv, resets):
    rows = set()
    for _ in range(resets):
        venv.reset()
        rows.update(int(r) for r in venv.rows)
    return rows


def test_spread_starts_cover_the_bin_and_log_the_draw(backflip):
    venv, draws = _vector_env(backflip, spread=0.1)
    rows = _start_rows(venv, 40)
    steps = venv.track.start_steps
    half = 0.05 * steps
    assert all(min(r, steps - r) <= half + 1 or abs(r - steps / 2) <= half + 1 for r in rows)
    assert len(rows) >= 8, "starts spread over the rows around both components' phases"
    for _ in range(12):
        venv.step(np.zeros((4, venv.action_dim), np.float32))
    log = venv.episodes.drain()
    assert len(log["components"]) >= 4
    for component, state in zip(log["components"], log["initial_states"]):
        np.testing.assert_allclose(state, draws[(0.0, 0.5)[component]], atol=1e-5)


def test_without_spread_starts_stay_at_the_component_phases(backflip):
    venv, _ = _vector_env(backflip, spread=0.0)
    rows = _start_rows(venv, 10)
    assert rows == {0, venv.track.start_index(0.5)}
    with pytest.raises(ValueError, match="spread"):
        _vector_env(backflip, spread=1.5)
