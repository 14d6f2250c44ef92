"""The dynamic balance term (`losses.dynamic_balance`): the zero-moment point, where the ground's
reaction must act for the centre of mass to accelerate as the motion says, over the support."""
import dataclasses
import functools

import numpy as np
import pytest
import torch

from services.reconstruction import ReconstructionConfig, reconstruct_track
from services.reconstruction.body import LINK_MASS_FRACTIONS, body_points
from services.reconstruction.losses import (
    GRAVITY,
    centre_acceleration,
    dynamic_balance,
    flight_deviation,
    static_balance,
    support_distance,
    whole_body_zero_moment_point,
    zero_moment_point,
)
from services.reconstruction.reconstruct import HEEL_POINTS, TOE_POINTS
from services.reconstruction.synthetic import make_standing_clip

FPS = 30.0


def test_the_acceleration_is_the_central_second_difference():
    t = torch.arange(20, dtype=torch.float64) / FPS
    com = torch.stack((1.5 * t * t, torch.zeros_like(t), 0.9 + 0.0 * t), dim=-1)  # x'' = 3 m/s^2
    accel = centre_acceleration(com, FPS, 3)
    assert accel.shape == (14, 3)
    assert torch.allclose(accel[:, 0], torch.full((14,), 3.0, dtype=torch.float64))
    assert torch.allclose(accel[:, 1:], torch.zeros((14, 2), dtype=torch.float64))


def test_the_zero_moment_point_lies_behind_a_body_that_speeds_up():
    com = torch.tensor([[0.2, -0.1, 1.0], [0.2, -0.1, 1.0]], dtype=torch.float64)
    still = zero_moment_point(com, torch.zeros(2, 3, dtype=torch.float64), 0.0)
    assert torch.allclose(still, com[:, :2])  # no acceleration: the static point
    forward = zero_moment_point(com, torch.tensor([[2.0, 0.0, 0.0], [0.0, 1.0, 0.0]], dtype=torch.float64), 0.0)
    # Pushed forward at 2 m/s^2 from 1 m up, the reaction acts 2 / g m behind the centre of mass.
    assert forward[0].tolist() == pytest.approx([0.2 - 2.0 / GRAVITY, -0.1])
    assert forward[1].tolist() == pytest.approx([0.2, -0.1 - 1.0 / GRAVITY])
    # A body that falls freely has no point of support: the lever stays bounded.
    falling = zero_moment_point(com[:1], torch.tensor([[1.0, 0.0, -GRAVITY]], dtype=torch.float64), 0.0)
    assert torch.isfinite(falling).all() and abs(float(falling[0, 0]) - 0.2) < 1.0


def test_the_whole_body_point_sees_a_spin_the_centre_of_mass_does_not():
    # Two equal masses, one 1.5 m up pushed forward at 2 m/s^2, one 0.5 m up pushed back as hard: the
    # centre of mass does not accelerate, but the body pitches forward, which needs the reaction
    # (2 x 1.5 - 2 x 0.5) / (2 g) = 1 / g m behind it.
    centres = torch.tensor([[[0.3, 0.0, 1.5], [0.1, 0.0, 0.5]]], dtype=torch.float64)
    accelerations = torch.tensor([[[2.0, 0.0, 0.0], [-2.0, 0.0, 0.0]]], dtype=torch.float64)
    masses = torch.tensor([0.5, 0.5], dtype=torch.float64)
    com = (masses.unsqueeze(-1) * centres).sum(-2)
    assert zero_moment_point(com, (masses.unsqueeze(-1) * accelerations).sum(-2), 0.0)[0].tolist() == pytest.approx([0.2, 0.0])
    assert whole_body_zero_moment_point(centres, masses, accelerations, 0.0)[0].tolist() == pytest.approx([0.2 - 1.0 / GRAVITY, 0.0])
    # One link is the centre of mass's own point.
    single = whole_body_zero_moment_point(com.unsqueeze(1), masses[:1] * 2, torch.tensor([[[1.0, -0.5, 0.3]]], dtype=torch.float64), 0.2)
    assert single[0].tolist() == pytest.approx(zero_moment_point(com, torch.tensor([[1.0, -0.5, 0.3]], dtype=torch.float64), 0.2)[0].tolist())


def feet(frames: int):
    """A right foot from x = 0 to 0.2 at y = -0.1, a left one at y = +0.1: (heels, toes) (T, 2, 3)."""
    heels = torch.tensor([[0.0, -0.1, 0.0], [0.0, 0.1, 0.0]], dtype=torch.float64).expand(frames, 2, 3)
    toes = torch.tensor([[0.2, -0.1, 0.0], [0.2, 0.1, 0.0]], dtype=torch.float64).expand(frames, 2, 3)
    return heels, toes


def test_a_centre_of_mass_that_jitters_over_its_support_costs_only_in_the_dynamic_term():
    frames = 30
    heels, toes = feet(frames)
    contacts = torch.ones(frames, 2, dtype=torch.float64)
    sideways = 0.03 * torch.tensor([(-1.0) ** (t // 3) for t in range(frames)], dtype=torch.float64)  # 3 cm, 5 Hz
    com = torch.stack((torch.full((frames,), 0.1, dtype=torch.float64), sideways, torch.full((frames,), 0.9, dtype=torch.float64)), dim=-1)
    assert float(static_balance(com, heels, toes, contacts, 0.01, 0.05).sum()) == 0.0
    jitter = dynamic_balance(com, heels, toes, contacts, 0.01, 0.05, FPS, 3)
    assert float(jitter.sum()) > 1.0
    # The same centre of mass, still, costs nothing in either.
    still = com.clone()
    still[:, 1] = 0.0
    assert float(dynamic_balance(still, heels, toes, contacts, 0.01, 0.05, FPS, 3).sum()) == 0.0
    # The end frames, with no central difference, keep the static point (0 here); a frame with no foot down costs nothing.
    assert jitter[:3].abs().sum() == 0.0 and jitter[-3:].abs().sum() == 0.0
    contacts[10] = 0.0
    assert float(dynamic_balance(com, heels, toes, contacts, 0.01, 0.05, FPS, 3)[10]) == 0.0


def test_limbs_that_shake_against_each_other_cost_only_with_the_whole_body_point():
    # An arm 1.4 m up and a leg 0.4 m up shaking 3 cm in depth against each other, the centre of mass
    # still over the feet: the centre of mass's point costs nothing, the whole body's does.
    frames = 30
    heels, toes = feet(frames)
    contacts = torch.ones(frames, 2, dtype=torch.float64)
    shake = 0.03 * torch.tensor([(-1.0) ** (t // 3) for t in range(frames)], dtype=torch.float64)
    centres = torch.zeros(frames, 2, 3, dtype=torch.float64)
    centres[:, :, 0] = 0.1
    centres[:, 0, 1], centres[:, 0, 2] = shake, 1.4
    centres[:, 1, 1], centres[:, 1, 2] = -shake, 0.4
    masses = torch.tensor([0.5, 0.5], dtype=torch.float64)
    com = (masses.unsqueeze(-1) * centres).sum(-2)
    assert float(dynamic_balance(com, heels, toes, contacts, 0.01, 0.05, FPS, 3).sum()) == 0.0
    assert float(dynamic_balance(com, heels, toes, contacts, 0.01, 0.05, FPS, 3, links=(centres, masses)).sum()) > 1.0


def test_a_body_in_the_air_is_charged_for_what_a_free_fall_would_not_do():
    frames = 20
    t = torch.arange(frames, dtype=torch.float64) / FPS
    heels, toes = feet(frames)
    ballistic = torch.stack((2.0 * t, torch.zeros_like(t), 1.0 + 1.5 * t - 0.5 * GRAVITY * t * t), dim=-1)
    accel = centre_acceleration(ballistic, FPS, 3)
    assert float(flight_deviation(ballistic[3:-3], accel, 0.0).abs().max()) < 1e-9
    airborne = torch.zeros(frames, 2, dtype=torch.float64)
    assert float(dynamic_balance(ballistic, heels, toes, airborne, 0.01, 0.05, FPS, 3, flight=True).sum()) < 1e-9
    # The same leap drifting sideways at 3 m/s^2 needs a push nothing gives: charged with the flight term only.
    drifting = ballistic.clone()
    drifting[:, 1] = 1.5 * t * t
    assert float(dynamic_balance(drifting, heels, toes, airborne, 0.01, 0.05, FPS, 3, flight=True).sum()) > 10.0
    assert float(dynamic_balance(drifting, heels, toes, airborne, 0.01, 0.05, FPS, 3).sum()) == 0.0


def test_the_config_names_a_bad_balance_mode():
    with pytest.raises(ValueError, match="balance must be one of static, dynamic, whole_body"):
        ReconstructionConfig(balance="zmp")
    with pytest.raises(ValueError, match="balance_window_s must be positive"):
        ReconstructionConfig(balance_window_s=0.0)


def both_feet_down(track, label_flipped):
    frames = len(label_flipped)
    return np.full((frames, 2), 0.9), np.ones((frames, 2), bool)


def zmp_from_support(motion, whole_body: bool = False) -> float:
    """Median distance (m) of the motion's zero-moment point (0.1 s either side; `whole_body`: of its
    links' masses, `whole_body_zero_moment_point`) from its feet's support."""
    with torch.no_grad():
        fit, _, com, centres = body_points(torch.as_tensor(motion.root_pos), torch.as_tensor(motion.root_rot),
                                           torch.as_tensor(motion.joint_rot), with_links=True)
        if whole_body:
            zmp = whole_body_zero_moment_point(centres[3:-3], torch.as_tensor(LINK_MASS_FRACTIONS),
                                               centre_acceleration(centres, FPS, 3), 0.0)
        else:
            zmp = zero_moment_point(com[3:-3], centre_acceleration(com, FPS, 3), 0.0)
        down = torch.ones(len(zmp), 2, dtype=fit.dtype)
        return float(support_distance(zmp, fit[3:-3, HEEL_POINTS, :2], fit[3:-3, TOE_POINTS, :2], down).median())


@functools.lru_cache(maxsize=1)
def jittering_stand() -> dict:
    """{balance mode: motion} of a person standing on both feet whose 3D reading jitters 6 cm in depth,
    each keypoint with its own noise, reconstructed in 120 iterations."""
    clip = make_standing_clip(frames=24, right_foot_misread_m=0.0, depth_noise_m=0.06, seed=2)
    config = ReconstructionConfig(iterations=120, ik_iterations=60, focal_length_px=600.0, up_from_balance=False)
    return {mode: reconstruct_track(clip.track, dataclasses.replace(config, balance=mode), "stand", both_feet_down)
            for mode in ("static", "dynamic", "whole_body")}


def reprojection(motion) -> float:
    return float(np.mean(motion.extras["reprojection_error_px"]))


def test_the_reconstruction_of_a_jittering_stand_balances_with_the_dynamic_term():
    # The static term leaves the centre of mass shaking over the feet (its point stays inside them),
    # the dynamic one charges the reaction such shaking would need (measured: the zero-moment point
    # 71 -> 39 cm from the support, 3.7 -> 3.9 px).
    made = jittering_stand()
    assert zmp_from_support(made["dynamic"]) < 0.7 * zmp_from_support(made["static"])
    assert reprojection(made["dynamic"]) < reprojection(made["static"]) + 1.0  # at little 2D cost


def test_the_whole_body_term_also_stills_the_limbs_shaking_in_depth():
    # Each keypoint's depth has its own noise, so the limbs shake against each other, which the centre
    # of mass's point does not see (measured: the whole body's zero-moment point 39 -> 23 cm from the
    # support, 3.88 -> 3.93 px).
    made = jittering_stand()
    assert zmp_from_support(made["whole_body"], whole_body=True) < 0.8 * zmp_from_support(made["dynamic"], whole_body=True)
    assert reprojection(made["whole_body"]) < reprojection(made["dynamic"]) + 1.0
