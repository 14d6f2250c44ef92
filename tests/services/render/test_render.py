"""`sfv render`: real MuJoCo off-screen rendering (OSMesa on CPU) to a real MP4, decoded back."""
from __future__ import annotations

import imageio.v2 as imageio
import numpy as np
import pytest

from learner.errors import SfvError
from services.cli import main
from services.export.rollout import episode_steps
from services.render.movie import RenderConfig, render_policy
from actors.envs.pushes import PushConfig, PushSchedule, apply_push
from services.training.evaluation import evaluate_policy
from services.training.policy_source import load_policy_source
from tests.services.export.test_export_onnx import make_tiny_run

pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
WIDTH, HEIGHT = 160, 120
CAPTION = slice(0, HEIGHT // 4)  # three caption lines over the black sky


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    path = tmp_path_factory.mktemp("render") / "walk_rsi"
    make_tiny_run(path)
    return path


@pytest.fixture(scope="module")
def source(run_dir):
    return load_policy_source(run_dir)


def decode(path) -> np.ndarray:
    with imageio.get_reader(path) as reader:  # iter_data: the reader's len() is inf for ffmpeg streams
        return np.stack([frame for frame in reader.iter_data()])


@pytest.fixture(scope="module")
def two_episodes(run_dir, tmp_path_factory, source):
    out = tmp_path_factory.mktemp("video") / "walk.mp4"
    assert main(["render", str(run_dir), "--out", str(out), "--episodes", "2", "--seconds", "1.0",
                 "--width", str(WIDTH), "--height", str(HEIGHT)]) == 0
    return out, decode(out)


def test_one_frame_per_control_step_of_each_episode(two_episodes, source):
    out, frames = two_episodes
    env = source.make_env()
    # The same episodes as `sfv eval` plays them (same seeds), capped at 1 s = 30 steps.
    lengths = [evaluate_policy(source.policy, env, 1, seed=k, init="fsi")["episode_length"] for k in range(2)]
    expected = sum(min(int(n), 30) + 1 for n in lengths)  # + the frame after reset
    assert frames.shape == (expected, HEIGHT, WIDTH, 3)
    assert sorted(p.name for p in out.parent.iterdir()) == ["walk.mp4"]  # no temp file left


def test_the_picture_changes_and_shows_a_caption(two_episodes):
    _, frames = two_episodes
    first, last = frames[0].astype(int), frames[len(frames) // 2 - 1].astype(int)
    assert np.abs(first - last).mean() > 1.0  # the character moved (or fell)
    caption = frames[:, CAPTION].astype(int)
    assert (caption.min(axis=-1) > 120).sum(axis=(1, 2)).min() > 30  # light text on the black sky, every frame
    changed = np.abs(caption[0] - caption[len(frames) // 2 - 1]).max(axis=-1) > 80
    assert changed[: HEIGHT // 12].sum() == 0 and changed.sum() > 20  # same label; time and return change


def test_ghost_is_visible_and_blue(source, tmp_path):
    """Character (tan), floor (tan checker) and sky (black) have red >= blue: blue pixels are the ghost."""
    env = source.make_env()
    render_policy(source.policy, env, tmp_path / "ghost.mp4", RenderConfig(width=WIDTH, height=HEIGHT, seconds=0.4))
    render_policy(source.policy, env, tmp_path / "plain.mp4", RenderConfig(width=WIDTH, height=HEIGHT, seconds=0.4, ghost=False))
    below_caption = slice(CAPTION.stop, None)
    for name, low, high in (("ghost", 0.01, 0.5), ("plain", 0.0, 0.001)):
        frames = decode(tmp_path / f"{name}.mp4")[:, below_caption].astype(int)
        blue = (frames[..., 2] - frames[..., 0]) > 30
        share = blue.mean(axis=(1, 2))
        assert low <= share.min() and share.max() <= high, (name, share.min(), share.max())


def test_push_schedule_lands_whole_pushes_inside_the_episode():
    config = PushConfig(count=4, impulse=40.0, duration_s=0.1, settle_s=0.5)
    schedule = PushSchedule(config, 30.0, 300, np.random.default_rng(1))
    assert len(schedule.starts) == 4 and schedule.steps_per_push == 3
    assert schedule.starts[0] >= 15 and schedule.starts[-1] + 3 <= 300
    assert np.all(np.diff(schedule.starts) >= 3)  # no overlap
    np.testing.assert_allclose(np.linalg.norm(schedule.forces, axis=1) * 3 / 30.0, 40.0)  # |F| T = impulse
    assert np.all(schedule.forces[:, 2] == 0)  # horizontal
    active = [schedule.active(step) for step in range(300)]
    assert sum(k >= 0 for k in active) == 12 and active[schedule.starts[2] + 1] == 2
    short = PushSchedule(config, 30.0, 20, np.random.default_rng(1))  # no room after settling
    assert len(short.starts) == 0 and short.active(17) == -1


def test_a_push_moves_the_character_along_its_direction(source):
    env = source.make_env()
    root = int(env.humanoid.body_ids[0])
    config = PushConfig(count=1, impulse=40.0, duration_s=0.1, settle_s=0.2)
    schedule = PushSchedule(config, 30.0, 12, np.random.default_rng(5))
    start = int(schedule.starts[0])
    velocities = {}
    for pushed in (False, True):
        for progress in episode_steps(source.policy, env, seed=0, init="fsi", seconds=0.4):
            if progress.step == start + schedule.steps_per_push:
                velocities[pushed] = env.data.qvel[0:3].copy()
                break
            apply_push(env.data, root, schedule if pushed else None, progress.step)
    direction = schedule.forces[0] / np.linalg.norm(schedule.forces[0])
    gained = (velocities[True] - velocities[False]) @ direction
    assert 0.3 < gained < 3.0  # ~impulse / 45 kg = 0.9 m/s, less what the joints and ground take


def test_pushes_are_drawn(source, tmp_path):
    env = source.make_env()
    config = RenderConfig(width=WIDTH, height=HEIGHT, seconds=0.6, pushes=PushConfig(count=1, settle_s=0.2, duration_s=0.1))
    summary = render_policy(source.policy, env, tmp_path / "push.mp4", config)
    assert summary["episodes"][0]["pushes"] == 1
    frames = decode(tmp_path / "push.mp4").astype(int)
    red = (frames[..., 0] > 170) & (frames[..., 1] < 110) & (frames[..., 2] < 110)
    # Nothing red before the push, then the arrow in the frames it acts (at 160x120 it covers 5-10
    # pixels a frame, depending on its direction against the camera).
    per_frame = red.sum(axis=(1, 2))
    assert per_frame[:6].sum() == 0 and (per_frame > 0).sum() >= 3 and per_frame.sum() > 20


def test_a_failing_render_leaves_nothing(source, tmp_path):
    class BrokenPolicy:
        calls = 0

        def act(self, obs, deterministic=True):
            self.calls += 1
            if self.calls > 3:
                raise RuntimeError("policy crashed")
            return source.policy.act(obs, deterministic=deterministic)

    with pytest.raises(RuntimeError, match="policy crashed"):
        render_policy(BrokenPolicy(), source.make_env(), tmp_path / "broken.mp4", RenderConfig(width=WIDTH, height=HEIGHT))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--out", "{tmp}/v.avi"], "must be an .mp4"),
        (["--out", "{tmp}/v.mp4", "--width", "101"], "even numbers"),
        (["--out", "{tmp}/v.mp4", "--episodes", "0"], "--episodes must be positive"),
        (["--out", "{tmp}/nowhere/v.mp4"], "does not exist"),
        (["--out", "{tmp}/v.mp4", "--phase", "1.5"], "--phase must be in [0, 1]"),
    ],
)
def test_bad_render_arguments_are_one_line_errors(run_dir, tmp_path, capsys, argv, message):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(["render", str(run_dir), *argv, "--seconds", "0.1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sfv: ") and message in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_onnx_without_run_needs_a_motion(tmp_path, capsys):
    assert main(["render", "--onnx", str(tmp_path / "p.onnx"), "--out", str(tmp_path / "v.mp4")]) == 2
    assert "needs --motion" in capsys.readouterr().err


def test_config_validation_rejects_odd_sizes():
    with pytest.raises(SfvError, match="even"):
        RenderConfig(width=99).validate()

