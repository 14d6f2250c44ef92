"""Property tests: any DeepMimic-style file either loads to a valid motion or is a MotionFormatError,
and any valid motion can drive the imitation env without producing non-finite observations."""
import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from actors.character.humanoid3d import Humanoid
from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.modes.sfv.config import SfvConfig
from actors.motion.reference_motion import MotionFormatError, ReferenceMotion
from actors.motion.formats.io import DEEPMIMIC_COLUMNS, load_motion
from actors.envs.modes.sfv.reward import RewardConfig
from actors.character.skeleton import NUM_JOINTS


@pytest.fixture(scope="module", autouse=True)
def in_scratch_dir(tmp_path_factory):
    """MuJoCo writes MUJOCO_LOG.TXT into the working directory when a random clip makes the
    simulation unstable; keep it out of the repository."""
    old = os.getcwd()
    os.chdir(tmp_path_factory.mktemp("mujoco_log"))
    yield
    os.chdir(old)


# Values that a broken exporter or a hand edit might put into a motion file.
awkward_values = st.one_of(
    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e300, -1e300, 1.7e308, -1.7e308,
                     float("nan"), float("inf"), float("-inf"), 10**400, -(10**400), True, None, "0.5", "abc", [1.0], {}]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**30), 10**30),
)
plausible = st.floats(-2.0, 2.0, allow_subnormal=False)


@st.composite
def deepmimic_documents(draw):
    """A plausible clip (random frame count and values), then a few random faults."""
    n_frames = draw(st.integers(0, 20))
    rows = []
    for _ in range(n_frames):
        rows.append([draw(st.floats(0.005, 0.2))] + draw(st.lists(plausible, min_size=DEEPMIMIC_COLUMNS - 1, max_size=DEEPMIMIC_COLUMNS - 1)))
    for _ in range(draw(st.integers(0, 3)) if rows else 0):
        row = draw(st.integers(0, n_frames - 1))
        if not rows[row]:
            continue  # emptied by an earlier width fault
        fault = draw(st.sampled_from(["value", "value", "duration", "zero_quat", "width"]))
        if fault == "value":
            rows[row][draw(st.integers(0, len(rows[row]) - 1))] = draw(awkward_values)
        elif fault == "duration":
            rows[row][0] = draw(st.sampled_from([0.0, -0.01, 1e-300, 5e-324, 1e-17, 1e300, 1.7e308]))
        elif fault == "zero_quat":
            start = draw(st.sampled_from([4, 8, 12, 16, 21]))
            rows[row][start:start + 4] = [0.0] * 4
        else:
            width = draw(st.sampled_from([0, 1, DEEPMIMIC_COLUMNS - 1, DEEPMIMIC_COLUMNS + 1, 100]))
            rows[row] = (rows[row] * 3)[:width]
    loop = draw(st.sampled_from(["wrap", "none", "WRAP", 3, None]))
    return {"Loop": loop, "Frames": rows}


def assert_valid(motion: ReferenceMotion):
    T = motion.num_frames
    assert T >= 2
    assert motion.root_pos.shape == (T, 3) and motion.root_rot.shape == (T, 4) and motion.joint_rot.shape == (T, NUM_JOINTS, 4)
    assert motion.frame_times[0] == 0.0 and (np.diff(motion.frame_times) > 0).all()
    for array in (motion.frame_times, motion.root_pos, motion.root_rot, motion.joint_rot,
                  motion._root_lin_vel, motion._root_ang_vel, motion._joint_ang_vel):
        assert np.isfinite(array).all()
    np.testing.assert_allclose(np.linalg.norm(motion.root_rot, axis=-1), 1.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(motion.joint_rot, axis=-1), 1.0, atol=1e-9)
    assert np.isfinite(motion.duration) and motion.duration > 0
    pose = motion.sample(np.linspace(0.0, 2.0 * motion.duration, 7))
    for array in (pose.root_pos, pose.root_rot, pose.joint_rot, pose.root_lin_vel, pose.root_ang_vel, pose.joint_ang_vel):
        assert np.isfinite(array).all()


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(doc=deepmimic_documents())
def test_any_deepmimic_file_loads_valid_or_raises_motion_format_error(doc):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "random_clip.txt"
        path.write_text(json.dumps(doc))
        try:
            motion = load_motion(path)
        except MotionFormatError as exc:
            event("rejected")
            message = str(exc)
            assert message.startswith(str(path)) and "\n" not in message
            return
        event("loaded")
        assert_valid(motion)


# --------------------------------------------------------------- valid clips in the env
@st.composite
def valid_motions(draw):
    """Well-formed clips: any frame count, uneven durations, any heights, and rotations from
    near the rest pose to anything (drawn from a seeded generator)."""
    n = draw(st.integers(2, 12))
    steps = np.array(draw(st.lists(st.floats(0.01, 0.2), min_size=n - 1, max_size=n - 1)))
    frame_times = np.concatenate(([0.0], np.cumsum(steps)))
    root_pos = np.array(draw(st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.2, 1.5)), min_size=n, max_size=n)))
    root_pos[:, :2] -= root_pos[0, :2]
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    spread = draw(st.sampled_from([0.0, 0.2, 1.0, 10.0]))  # 10: nearly uniform rotations
    q = np.concatenate((np.ones((n, 1 + 12, 1)), spread * rng.normal(size=(n, 1 + 12, 3))), axis=-1)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return ReferenceMotion("random", frame_times, root_pos, q[:, 0], q[:, 1:], loop=draw(st.booleans()))


HUMANOID = Humanoid()


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(motion=valid_motions(), seed=st.integers(0, 2**31 - 1), init=st.sampled_from(["fsi", "rsi"]),
       actions=st.sampled_from([("exp_map", 0.5), ("exp_map", None), ("axis_angle", None)]),
       reward=st.sampled_from([RewardConfig(), RewardConfig.sfv_paper()]))
def test_valid_motion_runs_in_env_with_finite_observations(motion, seed, init, actions, reward):
    parameterisation, residual = actions  # residual targets are exp-map offsets only
    config = EnvConfig(horizon_s=0.5, init=init, action_parameterisation=parameterisation, residual_action_scale=residual,
                       sfv=SfvConfig(reward=reward))
    env = ImitationEnv(motion, config, HUMANOID)
    obs, info = env.reset(seed=seed)
    assert np.isfinite(obs).all() and 0.0 <= info["phase"] <= 1.0
    rng = np.random.default_rng(seed)
    for _ in range(8):
        action = rng.uniform(-1.5, 1.5, size=env.action_space.shape)  # beyond the box: the env clips
        obs, reward, terminated, truncated, _ = env.step(action)
        assert obs.shape == (env.obs_dim,) and np.isfinite(obs).all()
        assert 0.0 <= reward <= 1.0 + 1e-9
        assert 0.0 <= obs[-1] <= 1.0
        if terminated or truncated:
            obs, _ = env.reset(seed=seed + 1)
            assert np.isfinite(obs).all()
