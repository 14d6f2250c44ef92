"""End-to-end reconstruction of a synthetic clip with a known answer, and its output file."""
import dataclasses

import numpy as np
import pytest
import torch

from actors.character import quaternion as qn
from actors.envs.imitation_env import ImitationEnv
from actors.character.kinematics import revolute_angle
from actors.motion.formats.io import load_motion, save_motion
from actors.character.skeleton import JOINT_IS_SPHERICAL
from learner.errors import SfvError
from services.reconstruction import JOINT_KEYPOINTS, ReconstructionConfig, reconstruct_on_ray, reconstruct_track
from services.reconstruction.body import REVOLUTE_LIMITS, SPHERICAL_LIMITS, body_points
from services.reconstruction.keypoints import observe
from services.reconstruction.metrics import evaluate
from services.reconstruction.synthetic import make_clip

FOCAL = 600.0  # the synthetic camera's; a video's focal length is a guess (max(width, height)) and biases depth
FAST = ReconstructionConfig(iterations=150, ik_iterations=100, focal_length_px=FOCAL)
HIPS = [JOINT_KEYPOINTS.index("RHip"), JOINT_KEYPOINTS.index("LHip")]


@pytest.fixture(scope="module")
def clip():
    return make_clip(frames=40, focal=FOCAL, pixel_noise=2.0, depth_noise_m=0.04, seed=0)


@pytest.fixture(scope="module")
def motion(clip):
    return reconstruct_track(clip.track, FAST, name="synthetic")


def test_reconstruction_reduces_joint_error_and_jitter_of_the_3d_prediction(clip, motion):
    raw = evaluate(motion.extras["raw_keypoints3d"], clip.joints3d, HIPS)
    reconstructed = evaluate(motion.extras["keypoints3d"], clip.joints3d, HIPS)
    assert reconstructed["pa_mpjpe_mm"] < 0.8 * raw["pa_mpjpe_mm"]
    assert reconstructed["mpjpe_mm"] < 0.8 * raw["mpjpe_mm"]
    assert reconstructed["accel_error_mm"] < 0.5 * raw["accel_error_mm"]
    assert float(np.mean(motion.extras["reprojection_error_px"])) < 6.0  # pixel noise is 2 px per coordinate


def test_motion_follows_the_true_root_path(clip, motion):
    # Up to the monocular scale ambiguity (the humanoid is the person here, so scale is right)
    # and the gauge (first root at the origin), the root moves like the true one.
    true_path = clip.root_pos - clip.root_pos[0]
    path = motion.root_pos - motion.root_pos[0]
    assert np.abs(np.linalg.norm(path[-1]) - np.linalg.norm(true_path[-1])) < 0.1


def test_joints_stay_in_their_limits(motion):
    spherical = qn.quat_to_axis_angle(motion.joint_rot[:, JOINT_IS_SPHERICAL])
    hinges = revolute_angle(motion.joint_rot[:, ~JOINT_IS_SPHERICAL])
    assert (spherical >= SPHERICAL_LIMITS[..., 0] - 1e-6).all() and (spherical <= SPHERICAL_LIMITS[..., 1] + 1e-6).all()
    assert (hinges >= REVOLUTE_LIMITS[:, 0] - 1e-6).all() and (hinges <= REVOLUTE_LIMITS[:, 1] + 1e-6).all()


def test_feet_touch_but_never_go_below_the_ground(motion):
    with torch.no_grad():
        _, corners = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot),
                                 torch.as_tensor(motion.joint_rot))
    lowest = corners[..., 2].flatten(1).min(dim=1).values.numpy()
    assert lowest.min() == pytest.approx(0.0, abs=1e-9)
    # The ground's tilt comes from the body's mean lean, a few degrees off here, so the feet of
    # a person crossing the image rise by a few centimetres; they still stay near the ground.
    assert np.median(lowest) < 0.1


def test_keypoints3d_are_the_motions_joints(motion):
    with torch.no_grad():
        fit, _ = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot),
                             torch.as_tensor(motion.joint_rot))
    assert np.allclose(fit.numpy()[:, :len(JOINT_KEYPOINTS)], motion.extras["keypoints3d"], atol=1e-6)


def test_saved_motion_loads_with_its_extras_and_drives_the_imitation_env(motion, tmp_path):
    path = save_motion(motion, tmp_path / "synthetic.npz")
    loaded = load_motion(path)
    frames = motion.num_frames
    assert loaded.num_frames == frames and not loaded.loop
    assert loaded.fps == pytest.approx(30.0)
    assert tuple(str(n) for n in loaded.extras["keypoint_names"]) == JOINT_KEYPOINTS
    shapes = {"keypoints3d": (frames, 12, 3), "raw_keypoints3d": (frames, 12, 3), "keypoints2d": (frames, 12, 2),
              "confidence": (frames, 12), "camera_rotation": (3, 3), "camera_position": (3,)}
    for key, shape in shapes.items():
        assert loaded.extras[key].shape == shape, key
    assert float(loaded.extras["fps"]) == pytest.approx(30.0)
    env = ImitationEnv(loaded)
    observation, _ = env.reset(seed=0)
    _, reward, *_ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert np.isfinite(observation).all() and 0.0 < reward <= 1.0


def test_label_flips_in_the_track_are_undone(clip):
    misread = np.zeros(len(clip.track), bool)
    misread[10:16] = True
    # The estimator's mirrored reading on frames 10..15: left and right swapped, depth reflected.
    names = list(clip.track.keypoint_names)
    swap = [names.index(n.replace("left", "#").replace("right", "left").replace("#", "right")) for n in names]
    keypoints2d, world3d = clip.track.keypoints2d.copy(), clip.track.world3d.copy()
    keypoints2d[misread] = keypoints2d[misread][:, swap]
    world3d[misread] = world3d[misread][:, swap] * np.array([1.0, 1.0, -1.0], dtype=np.float32)
    track = dataclasses.replace(clip.track, keypoints2d=keypoints2d, world3d=world3d)
    motion = reconstruct_track(track, dataclasses.replace(FAST, iterations=20, ik_iterations=30))
    assert np.array_equal(motion.extras["label_flipped"], misread)
    assert np.allclose(motion.extras["keypoints2d"], observe(clip.track).keypoints2d[:, :len(JOINT_KEYPOINTS)], atol=1e-4)


def test_unusable_tracks_are_one_line_errors(clip):
    nobody = dataclasses.replace(clip.track, valid=np.zeros(len(clip.track), bool))
    with pytest.raises(SfvError, match="no person"):
        reconstruct_track(nobody, FAST, name="empty.mp4")
    one_frame = dataclasses.replace(clip.track, valid=clip.track.valid[:1], keypoints2d=clip.track.keypoints2d[:1],
                                    confidence=clip.track.confidence[:1], world3d=clip.track.world3d[:1])
    with pytest.raises(SfvError, match="at least 2 frames"):
        reconstruct_track(one_frame, FAST, name="short.mp4")


@pytest.mark.integration
def test_reconstruction_as_a_ray_task_gives_the_same_motion(clip):
    config = dataclasses.replace(FAST, iterations=10, ik_iterations=10)
    local = reconstruct_track(clip.track, config, name="synthetic")
    remote = reconstruct_on_ray(clip.track, config, name="synthetic")
    assert remote.name == "synthetic" and remote.num_frames == local.num_frames
    assert np.allclose(remote.root_pos, local.root_pos, atol=1e-6)
    assert np.allclose(remote.extras["keypoints3d"], local.extras["keypoints3d"], atol=1e-6)
