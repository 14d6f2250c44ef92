"""A share of episodes starts at the reference's first frame, the rest from the usual source."""
from __future__ import annotations

import numpy as np
import pytest

from actors.envs.initial_states import BufferedStarts, FirstFrameStarts, ReferenceStarts


def test_share_of_first_frame_starts():
    starts = FirstFrameStarts(BufferedStarts(ReferenceStarts("rsi", np.random.default_rng(0))), 0.4,
                              np.random.default_rng(1))
    taken = [starts.take() for _ in range(3000)]
    first = [t for t in taken if t[0] == 0.0]
    assert abs(len(first) / len(taken) - 0.4) < 0.04
    assert all(component == -1 and state is None for _, component, state in first)  # never reported to ASI
    assert len({round(phase, 6) for phase, _, _ in taken}) > 1000  # the rest: RSI's phases
    with pytest.raises(ValueError, match="share"):
        FirstFrameStarts(starts, -0.1, np.random.default_rng(0))


def test_worker_starts_every_env_at_the_first_frame_with_share_one():
    from actors.envs.imitation_env import EnvConfig
    from actors.motion.formats.io import load_motion
    from actors.rollout.worker import RolloutWorker, WorkerSpec

    motion = load_motion("deepmimic:walk")
    worker = RolloutWorker(WorkerSpec(motion, EnvConfig(), 3, "rsi", 0, first_frame_share=1.0))
    worker.env.reset()
    assert [sub.row for sub in worker.env.envs] == [0, 0, 0]
    plain = RolloutWorker(WorkerSpec(motion, EnvConfig(), 3, "rsi", 0))
    plain.env.reset()
    assert any(sub.row != 0 for sub in plain.env.envs)
