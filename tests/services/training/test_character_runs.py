"""`--character`: the flag, the run's config.json remembering it, and `sfv eval` / `export` /
`render` building the run's body from it (a G1 run's policy reads 406 numbers and writes 29:
on a humanoid env it could not even act).

The G1 runs need its cached model (`sfv models fetch --robot g1`) and skip without it."""
from __future__ import annotations

import json

import pytest

from actors.character import g1_model
from learner.errors import SfvError
from services.cli import main
from services.training.config import TrainConfig
from services.training.flags import resolve
from services.training.run_dir import CONFIG_FILE, read_run_config
from tests.services.export.test_export_onnx import make_tiny_run
from tests.services.training.test_train_flags import parse

needs_g1 = pytest.mark.skipif(not g1_model.model_available(), reason="G1 model not cached (sfv models fetch --robot g1)")
pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")


def test_the_flag_sets_the_env_character_and_the_default_is_the_humanoid(tmp_path):
    from services.commands import train

    assert train.build_config(parse("--out", str(tmp_path / "a"))).env.character == "humanoid3d"
    assert train.build_config(parse("--out", str(tmp_path / "b"), "--character", "g1")).env.character == "g1"
    with pytest.raises(SystemExit):
        parse("--out", str(tmp_path / "c"), "--character", "atlas")


def test_a_mode_the_body_cannot_follow_is_one_line_naming_both():
    with pytest.raises(SfvError, match="sfv train: env mode movingcam follows the humanoid3d only, not the g1"):
        resolve({"env.character": "g1", "env.mode": "movingcam"}, {"env.character": "--character", "env.mode": "--env.mode"})


def test_config_json_remembers_the_character_and_older_files_read_as_the_humanoid(tmp_path):
    config = TrainConfig(out=str(tmp_path / "run"))
    config.env = type(config.env)(character="g1")
    saved = json.loads(json.dumps(config.to_dict()))
    assert saved["env"]["character"] == "g1" and TrainConfig.from_dict(saved).env.character == "g1"
    del saved["env"]["character"]  # a run written before the G1
    assert TrainConfig.from_dict(saved).env.character == "humanoid3d"


def test_a_robot_motion_for_the_humanoid_is_refused_in_one_line(tmp_path):
    import numpy as np

    from actors.character import g1_spec
    from actors.character.characters import character_named
    from actors.motion.character_reference import load_reference
    from actors.motion.robot_motion import RobotMotion, save_robot_motion

    frames = 3
    robot = RobotMotion("g1", "stand_g1", "test", 30.0, False, g1_spec.JOINT_NAMES, np.zeros((frames, 3)),
                        np.tile([1.0, 0, 0, 0], (frames, 1)), np.zeros((frames, g1_spec.NUM_JOINTS)))
    path = save_robot_motion(robot, tmp_path / "stand_g1.npz")
    with pytest.raises(SfvError, match="a motion for 'g1', not for 'humanoid3d'"):
        load_reference(str(path), character_named("humanoid3d"))
    reference = load_reference(str(path), character_named("g1"))  # no model files needed to read it
    assert reference.character == "g1" and reference.joint_rot.shape == (frames, 29, 4)


def test_robot_motion_and_reference_convert_both_ways():
    import numpy as np

    from actors.character import g1_spec
    from actors.character.characters import character_named
    from actors.motion.robot_motion import RobotMotion
    from actors.motion.robot_reference import robot_motion_of, robot_reference

    rng = np.random.default_rng(0)
    lo, hi = g1_spec.JOINT_LIMITS.T
    angles = rng.uniform(lo, hi, (5, g1_spec.NUM_JOINTS))
    quat = rng.normal(size=(5, 4))
    robot = RobotMotion("g1", "random_g1", "test", 25.0, True, g1_spec.JOINT_NAMES, rng.normal(size=(5, 3)),
                        quat / np.linalg.norm(quat, axis=1, keepdims=True), angles)
    g1 = character_named("g1")
    back = robot_motion_of(robot_reference(robot, g1), g1)
    np.testing.assert_allclose(back.joint_pos, angles, atol=1e-12)
    np.testing.assert_allclose(back.qpos(), robot.qpos(), atol=1e-12)
    assert (back.fps, back.loop, back.joint_names) == (25.0, True, g1_spec.JOINT_NAMES)


@pytest.fixture(scope="module")
def g1_run(tmp_path_factory):
    if not g1_model.model_available():
        pytest.skip("G1 model not cached (sfv models fetch --robot g1)")
    from actors.envs.imitation_env import EnvConfig

    run = tmp_path_factory.mktemp("g1") / "walk_g1"
    make_tiny_run(run, hidden=(32,), env=EnvConfig(character="g1", horizon_s=1.0))
    return run


@needs_g1
def test_eval_of_a_g1_run_builds_the_g1(g1_run, capsys):
    assert read_run_config(g1_run).env.character == "g1"
    assert main(["eval", str(g1_run), "--episodes", "2"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert result["motion"] == "deepmimic:walk_g1" and result["episodes"] == 2
    assert 0.0 <= result["normalized_return"] <= 1.0 and result["joint_rotation_error_rad"] is not None


@needs_g1
def test_export_onnx_and_render_of_a_g1_run(g1_run, tmp_path, capsys):
    onnx = tmp_path / "g1.onnx"
    assert main(["export", str(g1_run), "--onnx", str(onnx)]) == 0
    exported = json.loads(capsys.readouterr().out)
    assert (exported["obs_dim"], exported["act_dim"]) == (406, 29)
    from actors.motion.robot_motion import load_robot_motion

    rollout = tmp_path / "rollout_g1.npz"
    assert main(["export", str(g1_run), "--motion", str(rollout), "--seconds", "0.2"]) == 0
    written = json.loads(capsys.readouterr().out)["rollouts"][0]
    recorded = load_robot_motion(rollout, "g1")  # the robot's own file, checked against its joints and limits
    assert recorded.num_frames == written["frames"] and recorded.fps == 30.0
    from services.render.gl import select_backend

    try:
        select_backend()
    except SfvError as exc:
        pytest.skip(f"no OpenGL for the render: {exc}")
    video = tmp_path / "g1.mp4"
    assert main(["render", str(g1_run), "--out", str(video), "--seconds", "0.2", "--width", "64", "--height", "48"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["motion"] == "deepmimic:walk_g1" and summary["frames"] >= 2 and video.stat().st_size > 0
    assert json.loads((g1_run / CONFIG_FILE).read_text())["env"]["character"] == "g1"


@needs_g1
def test_export_bvh_of_a_g1_run_puts_the_rollout_on_the_robots_bodies(g1_run, tmp_path, capsys):
    """The same rollout as --motion's robot motion file, as BVH: its forward kinematics are MuJoCo's body positions."""
    import mujoco
    import numpy as np

    from actors.character.g1 import G1Model
    from actors.motion.formats.bvh import read_bvh, yup_to_zup_vec
    from actors.motion.formats.bvh_pose import bvh_forward_kinematics
    from actors.motion.formats.robot_bvh import robot_motion_qpos
    from actors.motion.robot_motion import load_robot_motion

    npz, bvh_path = tmp_path / "roll_g1.npz", tmp_path / "roll_g1.bvh"
    assert main(["export", str(g1_run), "--motion", str(npz), "--bvh", str(bvh_path), "--seconds", "0.5", "--units", "m"]) == 0
    written = json.loads(capsys.readouterr().out)["rollouts"][0]
    assert written["bvh"] == str(bvh_path) and sorted(p.name for p in tmp_path.iterdir()) == ["roll_g1.bvh", "roll_g1.npz"]
    bvh, recorded = read_bvh(bvh_path), load_robot_motion(npz, "g1")
    assert len(bvh.frames) == recorded.num_frames == written["frames"] and bvh.frame_time == pytest.approx(1 / 30.0)
    assert bvh.joints[0].name == "pelvis" and len(bvh.joints) == 30 and bvh.frames.shape[1] == 6 + 3 * 29
    positions = yup_to_zup_vec(bvh_forward_kinematics(bvh)[0])  # metres (--units m)
    g1 = G1Model()
    _, qpos = robot_motion_qpos(recorded, g1)
    data = mujoco.MjData(g1.model)
    for frame in range(recorded.num_frames):
        data.qpos[:] = qpos[frame]
        mujoco.mj_kinematics(g1.model, data)
        assert np.abs(positions[frame] - data.xpos[np.sort(g1.body_ids)]).max() < 1e-5


@needs_g1
def test_the_onnx_export_carries_a_robot_runtimes_metadata(g1_run, tmp_path):
    import numpy as np

    from actors.character import g1_spec
    from learner.onnx_export import OnnxPolicy
    from services.export.onnx_run import export_run_onnx
    from services.training.policy_source import load_policy_source

    out = tmp_path / "g1_runtime.onnx"
    export_run_onnx(g1_run, out)
    meta = {key: json.loads(value) for key, value in OnnxPolicy(out).metadata.items()}
    assert meta["sfv_runtime"] == "sfv-runtime-1" and meta["character"] == "g1"
    assert meta["joint_order"] == list(g1_spec.JOINT_NAMES)  # the actions' order
    np.testing.assert_allclose(meta["kp"], g1_spec.KP, rtol=1e-5)
    np.testing.assert_allclose(meta["kd"], g1_spec.KD, rtol=1e-5)
    np.testing.assert_allclose(meta["effort_limit"], g1_spec.EFFORT_LIMITS, rtol=1e-6)
    np.testing.assert_allclose(meta["armature"], g1_spec.ARMATURE, rtol=1e-5)
    np.testing.assert_allclose(meta["default_joint_pos"], g1_spec.standing_joint_angles())
    np.testing.assert_allclose(meta["target_limits"], g1_spec.JOINT_LIMITS.T, atol=1e-6)
    action = dict(meta["action"])
    # The per-joint residual range: +-1 reaches each motor's effort limit at rest.
    np.testing.assert_allclose(np.asarray(action.pop("scale")) * g1_spec.KP, g1_spec.EFFORT_LIMITS, rtol=1e-5)
    assert action == {"parameterisation": "exp_map", "dim": 29, "clip": [-1.0, 1.0],
                      "offset": "reference_targets", "lead_steps": 2, "elementwise": True, "residual_wrench": None}
    assert (meta["control_hz"], meta["physics_hz"], meta["reference_loop"]) == (30.0, 300.0, True)
    env = load_policy_source(g1_run).make_env()
    assert np.shape(meta["reference_targets"]) == (env.track.start_steps, 29)
    np.testing.assert_allclose(meta["reference_targets"], env.track.ctrl[:env.track.start_steps], atol=1e-6)
    # The layout names the numbers the env writes.
    layout = {block["name"]: block for block in meta["observation_layout"]}
    assert sum(block["size"] for block in layout.values()) == 406 and meta["observation_links"][0] == "pelvis"
    obs, _ = env.reset(seed=1)
    at = lambda name: obs[layout[name]["start"]:layout[name]["start"] + layout[name]["size"]]
    assert at("root_height")[0] == pytest.approx(env.data.qpos[2], abs=1e-6)
    assert at("phase")[0] == pytest.approx(env.phase, abs=1e-6)
    np.testing.assert_allclose(at("link_positions")[:3], 0.0, atol=1e-6)  # the root, relative to itself
    # The runtime's action map reproduces the env's PD targets.
    action = np.random.default_rng(0).uniform(-1.5, 1.5, 29)
    row = min(env.row + 1 + meta["action"]["lead_steps"], env.track.rows - 1)
    offset = np.asarray(meta["reference_targets"])[row % env.track.start_steps]
    lower, upper = np.asarray(meta["target_limits"])
    expected = np.clip(offset + np.asarray(meta["action"]["scale"]) * np.clip(action, -1, 1), lower, upper)
    targets = env.actions.targets_batch(action[None], np.zeros((1, 29)), env.track.ctrl[row:row + 1])
    np.testing.assert_allclose(targets[0], expected, atol=1e-5)
