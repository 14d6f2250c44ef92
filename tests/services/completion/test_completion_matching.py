"""Motion completion without the pose models: frame matching, q_bar fitting, the initial
state, the image panel and the command's input checks (all real: MuJoCo, the reconstruction's
fit, the DeepMimic clips)."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest
import torch

from actors.character import quaternion as qn
from actors.envs.imitation_env import ImitationEnv
from actors.motion.formats.io import load_motion
from learner.errors import SfvError
from services.cli import main
from services.completion.image_panel import draw_image_panel, panel_width
from services.completion.initial_state import initial_state, lift_out_of_floor, target_qpos
from services.completion.library import reference_rotations
from services.completion.matching import best_match, pose_distances, yaw_free_root
from services.completion.still_image import read_image
from services.completion.target_pose import fit_target_pose, level_camera_rotation
from services.reconstruction.body import body_points
from services.reconstruction.keypoints import fit_index

pytest.importorskip("pybullet_data", reason="the DeepMimic clips come with pybullet_data")
UP = np.array([0.0, 0.0, 1.0])


def random_quats(rng, shape) -> np.ndarray:
    return qn.quat_normalize(rng.normal(size=shape + (4,)))


@pytest.fixture(scope="module")
def envs():
    return [ImitationEnv(load_motion(name)) for name in ("deepmimic:walk", "deepmimic:run")]


@pytest.fixture(scope="module")
def references(envs):
    return [reference_rotations(env) for env in envs]


def test_root_distance_ignores_heading_and_finds_the_aligning_yaw():
    rng = np.random.default_rng(0)
    reference, target = random_quats(rng, (50,)), random_quats(rng, (50,))
    angle, yaw = yaw_free_root(reference, target)
    # Brute force over a fine grid of yaws: the closed form is the minimum, at its yaw.
    grid = np.linspace(-np.pi, np.pi, 7201)
    turned = qn.quat_mul(qn.quat_about_axis(grid, UP)[:, None], target[None])
    brute = 2.0 * np.arccos(np.clip(np.abs((turned * reference[None]).sum(-1)), 0.0, 1.0))
    np.testing.assert_allclose(angle, brute.min(axis=0), atol=2e-3)
    aligned = qn.quat_mul(qn.quat_about_axis(yaw, UP), target)
    np.testing.assert_allclose(2.0 * np.arccos(np.clip(np.abs((aligned * reference).sum(-1)), 0, 1)), angle, atol=1e-6)
    # A pure heading change costs nothing.
    turned_reference = qn.quat_mul(qn.quat_about_axis(rng.uniform(-3, 3, 50), UP), target)
    np.testing.assert_allclose(yaw_free_root(turned_reference, target)[0], 0.0, atol=1e-6)


def test_joint_distance_is_the_sum_of_joint_angles():
    rng = np.random.default_rng(1)
    joints = random_quats(rng, (12,))
    bent = joints.copy()
    bent[4] = qn.quat_mul(bent[4], qn.quat_about_axis(0.3, np.array([0.0, 1.0, 0.0])))
    bent[9] = -qn.quat_mul(bent[9], qn.quat_about_axis(-0.2, np.array([1.0, 0.0, 0.0])))  # -q: same rotation
    root = random_quats(rng, ())
    distances, _ = pose_distances(root, joints, np.stack([root, root]), np.stack([joints, bent]))
    np.testing.assert_allclose(distances, [0.0, 0.5], atol=1e-6)


def test_every_reference_row_matches_itself_whatever_the_heading(references):
    rng = np.random.default_rng(2)
    for skill, (root_rot, joint_rot) in enumerate(references):
        for row in range(len(root_rot)):
            turn = rng.uniform(-np.pi, np.pi)
            target_root = qn.quat_mul(qn.quat_about_axis(turn, UP), root_rot[row])
            match, per_skill = best_match(target_root, joint_rot[row], references)
            assert (match.skill, match.row) == (skill, row)
            assert match.distance < 1e-5
            assert abs(np.angle(np.exp(1j * (match.yaw + turn)))) < 1e-4  # the yaw undoes the turn
            assert len(per_skill) == 2 and match in per_skill


def landmarks_of_reference(root_rot, joint_rot, turn: float) -> np.ndarray:
    """Fit points of reference poses in a level camera's axes, hip-centred, as BlazePose would
    report them, with the person turned by `turn` about the vertical."""
    rows = len(root_rot)
    root = qn.quat_mul(qn.quat_about_axis(np.full(rows, turn), UP), root_rot)
    with torch.no_grad():
        points, _ = body_points(torch.zeros(rows, 3, dtype=torch.float64), torch.as_tensor(root), torch.as_tensor(joint_rot))
    points = points.numpy()
    points -= 0.5 * (points[:, [fit_index("RHip")]] + points[:, [fit_index("LHip")]])
    return points @ level_camera_rotation().T


def test_reference_frames_converted_to_q_bar_match_themselves(envs, references):
    """Reference poses -> landmarks -> the reconstruction's fit (q_bar) -> matched to their own frame."""
    root_rot, joint_rot = references[0]
    rows = np.array([0, 9, 17, 26, 34])
    turn = 0.7
    target = fit_target_pose(landmarks_of_reference(root_rot[rows], joint_rot[rows], turn), iterations=200, lr=0.05)
    for k, row in enumerate(rows):
        match, _ = best_match(target.root_rot[k], target.joint_rot[k], references)
        assert (match.skill, match.row) == (0, row)
        assert abs(np.angle(np.exp(1j * (match.yaw + turn)))) < 0.1
    # Feet on the ground: the walk's root stands about as high as the reference's.
    np.testing.assert_allclose(target.root_height, envs[0].track.qpos[rows, 2], atol=0.05)


def test_initial_state_is_q_bar_at_the_reference_heading_with_its_velocities(envs, references):
    env = envs[0]
    root_rot, joint_rot = references[0]
    row = 11
    target_root = qn.quat_mul(qn.quat_about_axis(1.0, UP), root_rot[row])  # the image's heading differs
    match, _ = best_match(target_root, joint_rot[row], references)
    state = initial_state(env, row, target_root, joint_rot[row], env.track.qpos[row, 2], match.yaw)
    obs, info = env.reset(options={"init": "state", "phase": row / env.track.start_steps, "state": state})
    assert info["start_step"] == row and np.isfinite(obs).all()
    reference = env.track.qpos[row]
    np.testing.assert_allclose(env.data.qpos[:2], reference[:2])  # root xy from the reference
    assert abs(abs(env.data.qpos[3:7] @ reference[3:7]) - 1.0) < 1e-8  # heading turned back onto the reference
    np.testing.assert_allclose(env.data.qpos[7:], reference[7:], atol=1e-8)
    np.testing.assert_allclose(env.data.qvel, env.track.qvel[row])  # velocities of the chosen frame


def test_a_pose_below_the_floor_is_lifted_out_of_it(envs, references):
    env = envs[0]
    root_rot, joint_rot = references[0]
    qpos = target_qpos(env, 5, root_rot[5], joint_rot[5], root_height=0.4, yaw=0.0)
    lift = lift_out_of_floor(env.model, qpos)
    assert lift > 0.3
    data = mujoco.MjData(env.model)
    data.qpos[:] = qpos
    mujoco.mj_forward(env.model, data)
    assert min((data.contact[i].dist for i in range(data.ncon)), default=0.0) > -1e-6


def test_image_panel_keeps_the_aspect_and_draws_the_keypoints():
    image = np.full((300, 200, 3), 40, np.uint8)
    keypoints = np.random.default_rng(3).uniform([20, 20], [180, 280], size=(33, 2))
    visibility = np.ones(33)
    panel = draw_image_panel(image, keypoints, visibility, height=120, max_width=400, min_visibility=0.5)
    assert panel.shape == (120, panel_width((200, 300), 120, 400), 3) == (120, 80, 3)
    scaled = np.round(keypoints * 120 / 300).astype(int)
    drawn = panel[scaled[:, 1], scaled[:, 0]]
    assert (np.abs(drawn.astype(int) - 40).max(axis=1) > 50).all()  # every keypoint is marked
    wide = draw_image_panel(np.full((100, 1000, 3), 200, np.uint8), keypoints * 0, visibility, 120, 400, 0.5)
    assert wide.shape == (120, 400, 3)  # 1000x100 scaled to 400x40, bars of 40 rows above and below
    assert (wide[:30] == 0).all() and (wide[-30:] == 0).all() and (wide[45:75, 100:300] == 200).all()


# ------------------------------------------------------------------------- bad input
def test_read_image_errors_name_the_file(tmp_path):
    with pytest.raises(SfvError, match="no such image file"):
        read_image(tmp_path / "missing.png")
    with pytest.raises(SfvError, match="not a file"):
        read_image(tmp_path)
    fake = tmp_path / "notes.png"
    fake.write_text("not an image at all\n")
    with pytest.raises(SfvError, match=r"notes\.png: not a readable image"):
        read_image(fake)
    empty = tmp_path / "empty.jpg"
    empty.write_bytes(b"")
    with pytest.raises(SfvError, match="not a readable image"):
        read_image(empty)


def text_file(folder):
    path = folder / "text.png"
    path.write_text("hello")
    return path


@pytest.mark.parametrize("make_image, message", [
    (lambda folder: folder / "missing.png", "missing.png: no such image file"),
    (text_file, "text.png: not a readable image"),
])
def test_cli_rejects_bad_images_before_loading_anything(tmp_path, capsys, make_image, message):
    image = make_image(tmp_path)
    out = tmp_path / "out.mp4"
    code = main(["complete", str(image), "--library", str(tmp_path / "no_run"), "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sfv: ") and message in err and len(err.splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted({image.name} & {"text.png"})  # nothing written


def test_cli_rejects_bad_arguments(tmp_path, capsys):
    image = tmp_path / "still.png"
    import cv2

    cv2.imwrite(str(image), np.zeros((32, 32, 3), np.uint8))
    cases = [
        (["--library", str(tmp_path), "--out", str(tmp_path / "a.mp4")], "not a run directory"),
        (["--library", str(tmp_path), "--out", str(tmp_path / "a.avi")], "must be an .mp4 file"),
        (["--library", str(tmp_path), "--out", str(tmp_path / "nowhere" / "a.mp4")], "does not exist"),
        (["--library", str(tmp_path), "--out", str(tmp_path / "a.mp4"), "--seconds", "0"], "--seconds must be"),
        (["--library", str(tmp_path), "--out", str(tmp_path / "a.mp4"), "--height", "101"], "even numbers"),
    ]
    for extra, message in cases:
        assert main(["complete", str(image), *extra]) == 2
        assert message in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["still.png"]
