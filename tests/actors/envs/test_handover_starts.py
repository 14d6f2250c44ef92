"""A window's episodes start from the previous window's states at phase 0 in the given share."""
from __future__ import annotations

import numpy as np
import pytest

from actors.envs.handover_starts import HandoverStarts
from actors.envs.initial_states import BufferedStarts, ReferenceStarts


def test_share_of_handover_starts_and_their_states():
    states = np.arange(12, dtype=np.float64).reshape(3, 4)
    starts = HandoverStarts(BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0))), states, 0.3,
                            np.random.default_rng(1))
    taken = [starts.take() for _ in range(2000)]
    handed = [t for t in taken if t[2] is not None]
    assert abs(len(handed) / len(taken) - 0.3) < 0.04
    assert all(phase == 0.0 and component == -1 for phase, component, _ in handed)
    assert {tuple(s) for _, _, s in handed} == {tuple(row) for row in states}
    others = [t for t in taken if t[2] is None]
    assert len({round(phase, 6) for phase, _, _ in others}) > 100  # RSI phases from the wrapped source


def test_bad_handover_states_are_refused():
    source = BufferedStarts(ReferenceStarts("fsi", np.random.default_rng(0)))
    with pytest.raises(ValueError, match="hand-over states"):
        HandoverStarts(source, np.full((2, 3), np.nan), 0.5, np.random.default_rng(0))
    with pytest.raises(ValueError, match="share"):
        HandoverStarts(source, np.zeros((2, 3)), 1.5, np.random.default_rng(0))


def test_worker_draws_handover_starts():
    from actors.envs.imitation_env import EnvConfig, ImitationEnv
    from actors.motion.formats.io import load_motion
    from actors.rollout.worker import RolloutWorker, WorkerSpec

    motion = load_motion("deepmimic:walk")
    env = ImitationEnv(motion, EnvConfig())
    env.reset(options={"init": "rsi", "phase": 0.5})
    state = env.state_vector()
    worker = RolloutWorker(WorkerSpec(motion, EnvConfig(), 2, "rsi", 0, handover_states=state[None], handover_share=1.0))
    worker.env.reset()
    for sub in worker.env.envs:
        assert sub.row == 0
        np.testing.assert_allclose(sub.state_vector(), state, atol=1e-9)
