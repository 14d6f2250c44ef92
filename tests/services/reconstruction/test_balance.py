"""The static-balance term (`losses.static_balance`): the whole-body centre of mass (`body.centre_of_mass`)
over the support of the contact feet, beyond a margin; and the up direction taken from balance
(`camera.balance_up`)."""
import dataclasses

import mujoco
import numpy as np
import pytest
import torch

from actors.character.humanoid import build_mjcf
from actors.character.skeleton import LINK_NAMES
from services.reconstruction import ReconstructionConfig, reconstruct_track
from services.reconstruction.body import PoseParams, body_points, centre_of_mass, motion_centre_of_mass
from services.reconstruction.camera import MAX_BALANCE_TURN_DEG, MIN_BALANCE_FRAMES, MIN_BALANCE_TURN_DEG, balance_up
from services.reconstruction.keypoints import fit_index, observe
from services.reconstruction.losses import static_balance, support_distance
from services.reconstruction.reconstruct import initialise
from services.reconstruction.synthetic import make_one_leg_clip, make_standing_clip

UNIT = 0.01
MARGIN = 0.05
HEELS = [fit_index("RHeel"), fit_index("LHeel")]
TOES = [fit_index("RToe"), fit_index("LToe")]
RIGHT_ONLY = np.array([[1.0, 0.0]])
BOTH = np.array([[1.0, 1.0]])


def test_the_centre_of_mass_is_mujocos():
    model = mujoco.MjModel.from_xml_string(build_mjcf())
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    data.qpos[:] = model.qpos0
    data.qpos[3:7] = rng.normal(size=4)
    data.qpos[7:] += rng.normal(0.0, 0.4, model.nq - 7)
    mujoco.mj_normalizeQuat(model, data.qpos)
    mujoco.mj_forward(model, data)
    bodies = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) for name in LINK_NAMES]
    com = centre_of_mass(torch.as_tensor(data.xpos[bodies]), torch.as_tensor(data.xmat[bodies].reshape(-1, 3, 3)))
    assert np.allclose(com.numpy(), data.subtree_com[bodies[0]], atol=1e-9)


def test_support_distance_of_one_foot_and_of_two():
    heels = torch.tensor([[[0.0, -0.1], [0.0, 0.1]]], dtype=torch.float64)
    toes = torch.tensor([[[0.2, -0.1], [0.2, 0.1]]], dtype=torch.float64)
    over_right = torch.tensor([[0.1, -0.1]], dtype=torch.float64)
    between = torch.tensor([[0.1, 0.0]], dtype=torch.float64)
    behind = torch.tensor([[-0.3, -0.1]], dtype=torch.float64)
    d = lambda com, contacts: float(support_distance(com, heels, toes, torch.as_tensor(contacts)))  # noqa: E731
    assert d(over_right, RIGHT_ONLY) == pytest.approx(0.0, abs=1e-9)
    assert d(between, RIGHT_ONLY) == pytest.approx(0.1)
    assert d(between, BOTH) == 0.0  # inside the two feet's hull
    assert d(torch.tensor([[0.1, 0.3]], dtype=torch.float64), BOTH) == pytest.approx(0.2)  # beside the left foot
    assert d(behind, BOTH) == pytest.approx(0.3)  # the right heel is nearest
    assert d(between, np.array([[0.0, 0.0]])) == 0.0  # no foot down: no support, no term


def standing() -> PoseParams:
    """One frame of the humanoid standing straight."""
    return PoseParams.create(np.array([[0.0, 0.0, 0.9]]), np.array([[1.0, 0.0, 0.0, 0.0]]), np.zeros((1, 8, 3)),
                             np.zeros((1, 4)))


def balance_of(params: PoseParams, contacts: np.ndarray) -> tuple[torch.Tensor, float]:
    """(the balance term, the centre of mass's horizontal distance from the support, m)."""
    fit, _, com = body_points(params.root_pos, params.root_quat(), params.joint_quats(), with_com=True)
    heels, toes, contacts = fit[:, HEELS], fit[:, TOES], torch.as_tensor(contacts)
    distance = support_distance(com[:, :2], heels[..., :2], toes[..., :2], contacts)
    return static_balance(com, heels, toes, contacts, UNIT, MARGIN).sum(), float(distance.detach())


def test_a_body_over_its_feet_costs_nothing():
    # Standing straight, the centre of mass lies between the feet (above the ankles, inside the hull
    # of the heels and toes); on one foot, leaning over it, within the margin.
    loss, distance = balance_of(standing(), BOTH)
    assert distance == 0.0 and float(loss.detach()) == 0.0


def test_a_centre_of_mass_off_the_single_contact_foot_is_pulled_over_it():
    params = standing()
    loss, distance = balance_of(params, RIGHT_ONLY)
    # On the right foot alone, the centre of mass is half the hip width (8.5 cm) beside the foot
    # (loss measured 2.6); Adam on the joints alone leans it over the foot (0.4 cm, loss 0).
    assert distance > MARGIN + 0.02 and float(loss.detach()) > 1.0
    optimiser = torch.optim.Adam(params.rotation_leaves(), lr=0.02)
    for _ in range(150):
        optimiser.zero_grad()
        loss, _ = balance_of(params, RIGHT_ONLY)
        loss.backward()
        optimiser.step()
        params.clamp_to_limits()
    after_loss, after = balance_of(params, RIGHT_ONLY)
    assert after < MARGIN + 0.005 and float(after_loss.detach()) < 0.1 * float(balance_of(standing(), RIGHT_ONLY)[0].detach())


# The term alone, on the up the body's axis gives (up from balance would already turn the world so
# that the centre of mass stands over the one foot the estimator calls down).
FAST = ReconstructionConfig(iterations=100, ik_iterations=60, focal_length_px=600.0, up_from_balance=False)


def right_foot_down(track, label_flipped):
    """The estimator's call: the person stands on the right foot only (the truth has both down)."""
    frames = len(label_flipped)
    return np.tile([0.9, 0.1], (frames, 1)), np.tile([True, False], (frames, 1))


@pytest.fixture(scope="module")
def standing_clip():
    return make_standing_clip(frames=16, right_foot_misread_m=0.0)


def com_to_right_foot(motion) -> float:
    """Mean horizontal distance (m) of the motion's centre of mass from its right heel-toe segment."""
    with torch.no_grad():
        fit, _ = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot),
                             torch.as_tensor(motion.joint_rot))
    com = torch.as_tensor(motion_centre_of_mass(motion.root_pos, motion.root_rot, motion.joint_rot))
    contacts = torch.as_tensor(np.tile(RIGHT_ONLY, (len(com), 1)))
    return float(support_distance(com[:, :2], fit[:, HEELS, :2], fit[:, TOES, :2], contacts).mean())


def test_the_reconstruction_moves_the_body_over_the_contact_foot(standing_clip):
    assert FAST.w_balance > 0  # on by default
    off = reconstruct_track(standing_clip.track, dataclasses.replace(FAST, w_balance=0.0), "standing",
                            contact_estimate=right_foot_down)
    on = reconstruct_track(standing_clip.track, dataclasses.replace(FAST, w_balance=100.0), "standing",
                           contact_estimate=right_foot_down)
    names = list(on.extras["final_loss_names"])
    assert off.extras["final_losses"][names.index("balance")] == 0.0  # off: not computed
    assert on.extras["final_losses"][names.index("balance")] > 0.0
    # The keypoints show both feet down, the centre of mass between them; told the right foot alone
    # is down, the fit leans over it at some 2D cost (measured: 9.7 -> 6.6 cm, 1.3 -> 1.8 px; the
    # default 50 gets 8.7 cm in these 100 iterations).
    assert com_to_right_foot(on) < com_to_right_foot(off) - 0.01


# --------------------------------------------------------------------------- up from balance
def up_error_deg(clip, up_from_balance: bool, contacts: np.ndarray) -> float:
    """Angle between the reconstruction's up and the clip camera's true vertical (degrees)."""
    obs = observe(clip.track)
    config = dataclasses.replace(ReconstructionConfig(), up_from_balance=up_from_balance)
    setup = initialise(obs, tuple(clip.track.image_size), config, torch.float64, contacts)
    true_up = clip.camera.rotation @ np.array([0.0, 0.0, 1.0])
    return float(np.degrees(np.arccos(np.clip(setup.camera.rotation[:, 2] @ true_up, -1.0, 1.0))))


def test_up_from_balance_finds_the_vertical_of_a_one_leg_stand():
    """On one leg with the other out to the side, the ankle-to-shoulder axis leans towards the raised
    leg (12 degrees here; 8-17 on the Pose2Sim cameras); the support-to-centre-of-mass direction is
    the vertical of a body that holds its balance (measured: 1.0 degree)."""
    clip = make_one_leg_clip()
    right_down = np.tile([True, False], (len(clip.root_pos), 1))
    body_axis, balance = up_error_deg(clip, False, right_down), up_error_deg(clip, True, right_down)
    assert body_axis > 8.0
    assert balance < 3.0


def tilted_stance(frames: int, tilt_deg: float, seed: int = 0):
    """Centres of mass 0.9 m above soles along an up `tilt_deg` from z, with 2 cm of sway."""
    rng = np.random.default_rng(seed)
    up = np.array([np.sin(np.radians(tilt_deg)), 0.0, np.cos(np.radians(tilt_deg))])
    soles = np.stack([rng.normal(0.0, 0.3, (frames, 3)), rng.normal(0.0, 0.3, (frames, 3))], axis=1)
    contacts = rng.random((frames, 2)) < 0.7
    contacts[:, 0] |= ~contacts[:, 1]  # a foot down in every frame
    support = (soles * contacts[..., None]).sum(axis=1) / contacts.sum(axis=1, keepdims=True)
    com = support + 0.9 * up + rng.normal(0.0, 0.02, (frames, 3))
    return com, soles, contacts, up


def test_balance_up_is_the_mean_support_to_centre_of_mass_direction():
    com, soles, contacts, up = tilted_stance(40, 12.0)
    found = balance_up(com, soles, contacts, np.ones(40, bool), np.array([0.0, 0.0, 1.0]))
    assert np.degrees(np.arccos(found @ up)) < 1.0


def test_balance_up_declines_what_it_cannot_tell():
    z = np.array([0.0, 0.0, 1.0])
    com, soles, contacts, _ = tilted_stance(40, 12.0)
    seen = np.ones(40, bool)
    few = contacts & (np.arange(40) < MIN_BALANCE_FRAMES - 1)[:, None]
    assert balance_up(com, soles, few, seen, z) is None  # too few frames with a foot down
    assert balance_up(com, soles, contacts, np.arange(40) < MIN_BALANCE_FRAMES - 1, z) is None  # the rest unseen
    scattered = soles.mean(axis=1) + np.random.default_rng(1).normal(0.0, 1.0, (40, 3))
    assert balance_up(scattered, soles, contacts, seen, z) is None  # directions that disagree
    far_com, far_soles, far_contacts, _ = tilted_stance(40, MAX_BALANCE_TURN_DEG + 10.0)
    assert balance_up(far_com, far_soles, far_contacts, seen, z) is None  # a turn no camera's tilt explains
    near_com, near_soles, near_contacts, _ = tilted_stance(40, 0.5 * MIN_BALANCE_TURN_DEG, seed=2)
    assert balance_up(near_com, near_soles, near_contacts, seen, z) is None  # within the sway: the body's up stays
