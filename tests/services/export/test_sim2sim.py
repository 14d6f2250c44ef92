"""`sfv sim2sim`: an exported policy replayed as a robot runtime would (`services/export/sim2sim/`).

A tiny run of each body (`make_tiny_run`: an untrained but visibly non-zero policy) is exported,
and the replay, built only from the ONNX file and the raw MJCF (the G1's cached `g1.xml`, the
humanoid3d's generated MJCF), is held against the env the policy trained in: the same observation
at the first frame and at the env's states along a rollout that passes a new cycle of the clip
(the root re-sync), the same rollout at the trained physics rate. The G1's tests need its cached
model (`sfv models fetch --robot g1`) and skip without it."""
from __future__ import annotations

import ast
import importlib.util
import json
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from actors.character import g1_model
from actors.character.characters import character_named
from actors.envs.imitation_env import EnvConfig
from services.cli import main
from services.export import sim2sim
from services.export.sim2sim import Replay, Sim2SimError, build_model, load_policy, run_sim2sim
from tests.services.export.test_export_onnx import REPO, make_tiny_run

pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
OBS_TOLERANCE = 1e-4
BODIES = ("humanoid3d", "g1")


def _robot_xml(character: str, folder: Path) -> Path:
    if character == "g1":
        return g1_model.model_dir() / g1_model.XML_FILE
    from actors.character.humanoid import build_mjcf

    path = folder / "humanoid3d.xml"
    path.write_text(build_mjcf())
    return path


@pytest.fixture(scope="module", params=BODIES)
def body(request, tmp_path_factory):
    """A body's exported tiny run: the ONNX file, the raw robot MJCF, the env it trained in."""
    character = request.param
    if character == "g1" and not g1_model.model_available():
        pytest.skip("G1 model not cached (sfv models fetch --robot g1)")
    from services.export.onnx_run import export_run_onnx
    from services.training.policy_source import load_policy_source

    folder = tmp_path_factory.mktemp(f"sim2sim_{character}")
    run = folder / "walk"
    make_tiny_run(run, hidden=(32,), env=EnvConfig(character=character, horizon_s=2.0))
    onnx = folder / "policy.onnx"
    export_run_onnx(run, onnx)
    env = load_policy_source(str(run)).make_env()
    return SimpleNamespace(character=character, onnx=onnx, xml=_robot_xml(character, folder), env=env, policy=load_policy(onnx))


def _replay(body, physics_hz: float | None = None) -> Replay:
    hz = body.env.config.physics.physics_hz if physics_hz is None else physics_hz
    return Replay(body.policy, build_model(body.policy.meta, body.xml, hz), body.xml)


def test_the_observation_is_the_envs_at_the_first_frame_and_along_a_rollout(body):
    env, replay = body.env, _replay(body)
    env_obs, _ = env.reset(options={"init": "fsi"})
    np.testing.assert_array_less(np.abs(replay.reset() - env_obs), OBS_TOLERANCE)
    steps = env.track.start_steps + 3  # past the clip's first new cycle, where the reference root re-syncs
    assert env.motion.loop and any(env.track.phase[r] < env.track.phase[r - 1] for r in range(1, steps + 1))
    moved = 0.0
    for _ in range(steps):
        env_obs, *_ = env.step(body.policy.act(env_obs))
        replay.data.qpos[:] = env.data.qpos  # the env's state; the replay keeps its own row and root sync
        replay.data.qvel[:] = env.data.qvel
        obs = replay.advance()
        worst = np.abs(obs - env_obs).max()
        assert worst < OBS_TOLERANCE, f"row {replay.row}: {worst:.3g}"
        moved = max(moved, float(np.abs(env.data.qvel).max()))
    assert moved > 0.5  # the compared states move (velocities are not all zero)


def test_the_reference_poses_ahead_are_the_envs(walk_clip, tmp_path):
    """The optional block of the reference's poses ahead (no tiny run: the metadata straight from an env)."""
    from actors.envs.imitation_env import ImitationEnv
    from services.export.runtime_metadata import runtime_metadata

    env = ImitationEnv(walk_clip, EnvConfig(reference_pose_obs_steps=(1, 10), horizon_s=1.0))
    meta = {key: json.loads(value) for key, value in runtime_metadata(env).items()}
    assert "reference_poses" in [block["name"] for block in meta["observation_layout"]]
    model = build_model(meta, _robot_xml("humanoid3d", tmp_path), env.config.physics.physics_hz)
    observer, data = sim2sim.Observer(model, meta), mujoco.MjData(model)
    obs, _ = env.reset(options={"init": "fsi"})
    for _ in range(4):
        data.qpos[:], data.qvel[:] = env.data.qpos, env.data.qvel
        sim2sim.update_kinematics(model, data)
        np.testing.assert_array_less(np.abs(observer.observe(data, env.row, env.root_sync.offset[0]) - obs), OBS_TOLERANCE)
        obs, *_ = env.step(np.full(env.action_space.shape, 0.3))


def test_the_rollout_at_the_trained_rate_is_the_envs(body):
    env, replay = body.env, _replay(body)
    env_obs, _ = env.reset(options={"init": "fsi"})
    obs = replay.reset()
    for _ in range(5):
        env_obs, *_ = env.step(body.policy.act(env_obs))
        obs = replay.step(body.policy.act(obs))
        np.testing.assert_allclose(replay.data.ctrl, env.data.ctrl, atol=1e-5)  # the action map: the same PD targets
        np.testing.assert_allclose(replay.data.qpos, env.data.qpos, atol=1e-5)  # the actuators: the same motion
        np.testing.assert_array_less(np.abs(obs - env_obs), 1e-4)
    assert np.abs(env.data.qpos - env.track.qpos[5]).max() > 1e-3  # the policy moved it off the reference


def test_the_report_at_1khz_is_written_atomically(body, tmp_path):
    out = tmp_path / "sim2sim.json"
    report = run_sim2sim(body.onnx, body.xml, physics_hz=1000.0, seconds=1.0, json_out=out)
    assert json.loads(out.read_text()) == json.loads(json.dumps(report))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim2sim.json"]
    episode, = report["episodes"]
    assert (report["physics_hz"], report["trained_physics_hz"]) == (1000.0, 300.0)
    assert episode["seconds_survived"] == pytest.approx(episode["control_steps"] / 30.0) and 0 < episode["seconds_survived"] <= 1.0
    assert abs(episode["physics_steps"] - episode["control_steps"] * 1000.0 / 30.0) <= 1.0  # 33 or 34 steps a control period
    assert episode["mean_joint_target_error_rad"] > 0 and 0.0 <= episode["max_torque_saturation_fraction"] <= 1.0
    feet = character_named(body.character).feet  # a walk's rule: only the feet may touch the floor
    assert f"the bodies the clip allows ({', '.join(feet)}" in report["fall_rule"] and episode["fell"] == (episode["fall_reason"] is not None)


def test_the_feet_come_from_the_model_and_a_lying_body_has_fallen(body):
    replay = _replay(body)
    rule = sim2sim.FallRule(replay.model, sim2sim.floor_name(replay.model), replay.observer.root, 0.0)
    assert set(rule.allowed) == set(character_named(body.character).feet)
    replay.reset()
    mujoco.mj_forward(replay.model, replay.data)
    assert rule(replay.data) is None  # the first frame stands on its feet
    replay.data.qpos[2] = 0.12
    replay.data.qpos[3:7] = [np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0]  # on its side, at the floor
    mujoco.mj_forward(replay.model, replay.data)
    assert rule(replay.data).endswith("touched the floor")


def test_the_bodies_allowed_on_the_floor_are_the_files_and_another_lying_there_has_fallen(body):
    replay = _replay(body)
    lying = replay.reset() is not None and replay.data
    lying.qpos[2] = 0.12
    lying.qpos[3:7] = [np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0]  # on its side, at the floor
    mujoco.mj_forward(replay.model, lying)
    touching = {mujoco.mj_id2name(replay.model, mujoco.mjtObj.mjOBJ_BODY, replay.model.geom_bodyid[g])
                for pair in lying.contact.geom[:lying.ncon] for g in pair if g != replay.model.ngeom and replay.model.geom_bodyid[g] > 0}
    assert touching - set(character_named(body.character).feet)  # something but the feet touches
    floor = sim2sim.floor_name(replay.model)
    allowed = sorted(touching)
    assert sim2sim.FallRule(replay.model, floor, replay.observer.root, 0.0, allowed)(lying) is None
    fall = sim2sim.FallRule(replay.model, floor, replay.observer.root, 0.0, allowed[1:])(lying)
    assert fall is not None and fall.endswith("touched the floor")
    with pytest.raises(ValueError, match="nose"):
        sim2sim.FallRule(replay.model, floor, replay.observer.root, 0.0, ("nose",))


@pytest.mark.parametrize("character", BODIES)
def test_a_cartwheels_file_allows_its_hands_on_the_floor_and_a_walks_only_its_feet(character):
    from actors.envs.imitation_env import ImitationEnv
    from actors.motion.formats.io import load_motion
    from services.export.runtime_metadata import runtime_metadata

    if character == "g1" and not g1_model.model_available():
        pytest.skip("G1 model not cached (sfv models fetch --robot g1)")
    spec = character_named(character)
    allowed = {}
    for clip in ("walk", "cartwheel"):  # a humanoid clip, retargeted onto the G1 by the env
        env = ImitationEnv(load_motion(f"deepmimic:{clip}"), EnvConfig(character=character, horizon_s=1.0))
        allowed[clip] = json.loads(runtime_metadata(env)["ground_contacts"])["allowed_bodies"]
    hands = {spec.link_names[i] for i in spec.end_effector_links} - set(spec.feet)
    assert set(allowed["walk"]) == set(spec.feet)
    assert hands and set(allowed["cartwheel"]) == set(spec.feet) | hands


def test_the_command_prints_the_report_and_finds_the_robot_xml(body, tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["sim2sim", str(body.onnx), "--physics-hz", "600", "--seconds", "0.3", "--json", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads(out.read_text()) and printed["physics_hz"] == 600.0 and printed["character"] == body.character


def test_the_replay_imports_no_training_code(body):
    """Run in a fresh interpreter: only onnxruntime, mujoco and numpy beside the standard library."""
    script = (f"import json, sys\nfrom services.export.sim2sim import run_sim2sim\n"
              f"run_sim2sim({str(body.onnx)!r}, {str(body.xml)!r}, physics_hz=500.0, seconds=0.2)\n"
              "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in ('learner', 'actors', 'torch', 'gymnasium')"
              " or m.startswith(('services.training', 'services.commands')))))")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, cwd=REPO)
    assert result.returncode == 0, result.stderr[-2000:]
    assert json.loads(result.stdout.strip().splitlines()[-1]) == []
    folder = Path(sim2sim.__file__).parent  # the package: every file of it, not only __init__.py
    sources = sorted(folder.rglob("*.py"))
    assert {"__init__.py", "policy.py", "model.py", "observer.py", "replay.py"} <= {s.name for s in sources}
    imported = set()
    for source in sources:
        module = ".".join((sim2sim.__name__, *source.relative_to(folder).with_suffix("").parts)).removesuffix(".__init__")
        package = module if source.name == "__init__.py" else module.rpartition(".")[0]
        tree = ast.parse(source.read_text())
        imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        imported |= {importlib.util.resolve_name("." * n.level + (n.module or ""), package) if n.level else n.module
                     for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    own = {m for m in imported if m == sim2sim.__name__ or m.startswith(sim2sim.__name__ + ".")}  # the package's own files
    assert {m.split(".")[0] for m in imported - own} <= {"__future__", "dataclasses", "json", "math", "os", "pathlib", "tempfile",
                                                        "mujoco", "numpy", "onnxruntime"}


# ------------------------------------------------------------------------------ bad input
def _without_key(onnx: Path, key: str, out: Path) -> Path:
    import onnx as onnx_lib

    model = onnx_lib.load(str(onnx))
    kept = [p for p in model.metadata_props if p.key != key]
    del model.metadata_props[:]
    model.metadata_props.extend(kept)
    onnx_lib.save(model, str(out))
    return out


def _with_key(onnx: Path, key: str, value, out: Path) -> Path:
    """The file with metadata `key` set to `value` (JSON)."""
    import onnx as onnx_lib

    model = onnx_lib.load(str(_without_key(onnx, key, out)))
    entry = model.metadata_props.add()
    entry.key, entry.value = key, json.dumps(value)
    onnx_lib.save(model, str(out))
    return out


def _robot_without(xml: Path, joint: str, out: Path) -> Path:
    """The robot's MJCF with `joint` renamed (meshes still found)."""
    text = xml.read_text().replace(f'name="{joint}"', f'name="{joint}_renamed"')
    out.write_text(text.replace('meshdir="assets"', f'meshdir="{xml.parent / "assets"}"'))
    return out


def test_bad_inputs_are_one_line_errors_naming_the_file(body, tmp_path, capsys):
    text = tmp_path / "not_a_policy.onnx"
    text.write_text("hello")
    stale = _without_key(body.onnx, "reference_track", tmp_path / "stale.onnx")
    joint = body.policy.meta["joint_order"][-1]
    robot = _robot_without(body.xml, joint, tmp_path / "robot.xml")
    odd = _with_key(body.onnx, "ground_contacts", {"allowed_bodies": ["nose"]}, tmp_path / "odd.onnx")
    bad = _with_key(body.onnx, "ground_contacts", ["pelvis"], tmp_path / "bad.onnx")
    cases = [((text, body.xml), f"{text}: not an ONNX model"),
             ((stale, body.xml), f"{stale}: no robot-runtime metadata key reference_track"),
             ((body.onnx, robot), f"{robot}: no joint {joint}"),
             ((body.onnx, tmp_path / "missing.xml"), f"{tmp_path / 'missing.xml'}: no such robot MJCF file"),
             ((odd, body.xml), f"{odd}: ground_contacts: allowed floor-contact bodies ['nose'] are not bodies of the model {body.xml}"),
             ((bad, body.xml), f"{bad}: metadata ground_contacts is not")]
    for (policy, xml), message in cases:
        with pytest.raises(Sim2SimError) as caught:
            run_sim2sim(policy, xml, seconds=0.1)
        assert str(caught.value).startswith(message) and "\n" not in str(caught.value)
        assert main(["sim2sim", str(policy), "--robot-xml", str(xml), "--seconds", "0.1"]) == 2
        err = capsys.readouterr().err.strip()
        assert err == f"sfv: {caught.value}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.onnx", "not_a_policy.onnx", "odd.onnx", "robot.xml", "stale.onnx"]


def test_a_policy_with_a_residual_root_wrench_replays_its_joints_alone(tmp_path, capsys):
    from services.export.onnx_run import export_run_onnx
    from services.training.policy_source import load_policy_source

    run = tmp_path / "helped"
    make_tiny_run(run, hidden=(32,), env=EnvConfig(horizon_s=2.0, residual_force=0.5))
    onnx = tmp_path / "policy.onnx"
    export_run_onnx(run, onnx)
    env = load_policy_source(str(run)).make_env()
    policy = load_policy(onnx)
    xml = _robot_xml("humanoid3d", tmp_path)
    replay = Replay(policy, build_model(policy.meta, xml, env.config.physics.physics_hz), xml)
    env_obs, _ = env.reset(options={"init": "fsi"})
    obs = replay.reset()
    action = policy.act(obs)
    assert action.shape == (34,) and np.abs(action[28:]).max() > 0  # the wrench's outputs are there
    env.step(policy.act(env_obs))
    replay.step(action)
    np.testing.assert_allclose(replay.data.ctrl, env.data.ctrl, atol=1e-5)  # the joints' targets are the env's
    assert main(["sim2sim", str(onnx), "--robot-xml", str(xml), "--seconds", "0.2"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out.splitlines()[-1])["residual_wrench_dropped"] is True and "residual root force" in err
