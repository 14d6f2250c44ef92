"""002's scene reward (actors/envs/scene_reward.py, eq. 10-12): each term is 1 at a perfect contact,
alignment and landing, falls with the distance, and is 0 where the reference touches no box;
our r_height term pays for the reference's centre-of-mass height while on a box."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from actors.motion.formats.io import load_motion
from actors.arenas.scene import Box, Scene, SceneFrame
from actors.envs.scene_reward import CONTACT_LIFT, GRAVITY, SceneContacts, SceneReward, SceneRewardConfig

SCENE = Scene((Box("step", along=1.0, height=0.3, size=(0.8, 0.6), lateral=0.2),))
FRAME = SceneFrame(origin=(0.5, -1.0), yaw=np.pi / 2)  # heading +y: along maps to world y
E = SCENE.vector()[None]
TOP_CENTRE = np.array([0.5 - 0.2, -1.0 + 1.0, 0.3])  # lateral +0.2 is world -x
TAU, OFFSET = 0.4, np.array([0.1, -0.2, 0.8])


COM_HEIGHT = np.array([1.2, 1.2, 1.1, 0.9])  # the reference's centre of mass per row
PAPER_TERMS = SceneRewardConfig(w_height=0.0)  # eq. 10-12 alone


def _reward(config=PAPER_TERMS):
    target = np.array([[0, -1, -1, -1], [-1, -1, 0, -1], [-1, -1, -1, -1], [-1, -1, -1, -1]])
    contacts = SceneContacts(target, air_box=np.array([-1, -1, 0, -1]), air_limb=np.array([0, 0, 0, 0]),
                             air_time=np.array([0.0, 0.0, TAU, 0.0]), air_offset=np.array([np.zeros(3), np.zeros(3), OFFSET, np.zeros(3)]),
                             com_height=COM_HEIGHT)
    return SceneReward(SCENE, FRAME, contacts, config)


def _call(reward, row, limbs, front=(0.0, 1.0, 0.0), com=np.zeros(3), com_vel=np.zeros(3)):
    terms = np.zeros((1, 4))
    total = reward.batch(np.array([row]), limbs[None], np.array([front]), com[None], com_vel[None], E, terms)
    return float(total[0]), terms[0]


def _limbs(right_foot=None, right_hand=None):
    limbs = np.full((4, 3), 5.0)
    if right_foot is not None:
        limbs[0] = right_foot
    if right_hand is not None:
        limbs[2] = right_hand
    return limbs


def test_a_foot_in_its_zone_facing_the_box_scores_one_and_distance_lowers_it():
    reward = _reward()
    on_zone = TOP_CENTRE + [0.05, 0.05, CONTACT_LIFT[0]]  # inside the centred quarter
    total, terms = _call(reward, 0, _limbs(right_foot=on_zone))
    assert terms[0] == pytest.approx(1.0) and terms[1] == pytest.approx(1.0) and terms[2] == 0.0
    assert total == pytest.approx(0.5 + 0.2)
    dists = [_call(reward, 0, _limbs(right_foot=on_zone + [0.0, 0.0, d]))[1][0] for d in (0.05, 0.1, 0.2, 0.4)]
    assert all(a > b for a, b in zip(dists, dists[1:])) and dists[0] == pytest.approx(np.exp(-15 * 0.05 ** 2))
    outside = _call(reward, 0, _limbs(right_foot=TOP_CENTRE + [0.0, 0.2 + 0.1, CONTACT_LIFT[0]]))[1][0]
    assert outside == pytest.approx(np.exp(-15 * 0.1 ** 2))  # the zone's half length is 0.2 m
    turned = _call(reward, 0, _limbs(right_foot=on_zone), front=(1.0, 0.0, 0.0))[1][1]
    assert turned == pytest.approx(np.exp(-1.0))


def test_the_hand_zone_is_the_right_near_corner():
    reward = _reward()
    corner = TOP_CENTRE + [0.3 * 0.75, -0.4 * 0.75, CONTACT_LIFT[2]]  # near (-along), right (-lateral = +x)
    assert _call(reward, 1, _limbs(right_hand=corner))[1][0] == pytest.approx(1.0)
    assert _call(reward, 1, _limbs(right_hand=TOP_CENTRE + [0, 0, CONTACT_LIFT[2]]))[1][0] < 0.9


def test_the_ballistic_landing_on_the_zone_scores_one_in_the_air():
    reward = _reward()
    land = TOP_CENTRE + [0.0, 0.0, 0.0]
    velocity = np.array([0.0, 1.5, 2.0])
    com = land + OFFSET - velocity * TAU - 0.5 * GRAVITY * TAU ** 2
    total, terms = _call(reward, 2, _limbs(), com=com, com_vel=velocity)
    assert terms[2] == pytest.approx(1.0) and terms[0] == terms[1] == 0.0 and total == pytest.approx(0.3)
    short = _call(reward, 2, _limbs(), com=com, com_vel=velocity - [0.0, 1.0, 0.0])[1][2]
    assert short == pytest.approx(np.exp(-5 * (1.0 * TAU - 0.2) ** 2))  # 0.4 m short, 0.2 m of it inside the zone


def test_no_box_contact_no_scene_reward_and_a_batch_matches_rows():
    reward = _reward()
    assert _call(reward, 3, _limbs(right_foot=TOP_CENTRE))[0] == 0.0
    rows = np.array([0, 3, 0])
    limbs = np.stack([_limbs(right_foot=TOP_CENTRE + [0, 0, CONTACT_LIFT[0] + d]) for d in (0.0, 0.0, 0.1)])
    out = reward.batch(rows, limbs, np.tile([0.0, 1.0, 0.0], (3, 1)), np.zeros((3, 3)), np.zeros((3, 3)), np.repeat(E, 3, 0))
    singles = [_call(reward, r, limbs[i])[0] for i, r in enumerate(rows)]
    np.testing.assert_allclose(out, singles)
    np.testing.assert_allclose(reward.max_rewards, [0.7, 0.7, 0.3, 0.0])


def test_the_box_clip_reference_earns_the_scene_reward_on_the_true_box():
    """Playing the synthetic clip's own reference on its true box: near-full r_dist and r_align
    on the box, r_com during the flight; 0.3 m too high a box lowers r_dist."""
    from actors.envs.imitation_env import EnvConfig, ImitationEnv

    scenes = Path(__file__).resolve().parents[3] / "bench" / "scenes"
    env = ImitationEnv(load_motion(str(scenes / "box_jump.npz")), EnvConfig(scene=str(scenes / "box_jump_truth.yaml"), scene_randomise=False))
    contacts = env.scene_reward.contacts
    on_box, flying = np.flatnonzero(contacts.active.any(axis=1)), np.flatnonzero(contacts.air_box >= 0)
    assert on_box.size > 10 and flying.size > 8 and on_box.min() > flying.max()

    def terms_at(row, e):
        env.set_reference_state(row)
        env.features.capture(0, env.data)
        terms = np.zeros((1, 4))
        env.scene_reward.batch(np.array([row]), env.features.pos[:, env.scene_limbs], env.features.root_xmat[:, ::3],
                               env.features.com, env.features.com_vel, np.asarray(e, float)[None], terms)
        return terms[0]

    truth = env.scene.vector()
    assert min(terms_at(r, truth)[0] for r in on_box[2:]) > 0.97
    assert np.mean([terms_at(r, truth)[2] for r in flying[len(flying) // 2:]]) > 0.9
    assert terms_at(on_box[5], truth + [0.0, 0.3])[0] < 0.3
    assert min(terms_at(r, truth)[3] for r in on_box) > 0.999  # the reference's own centre of mass


def test_height_pays_the_reference_centre_of_mass_height_on_a_box_only():
    reward = _reward(SceneRewardConfig())
    on_zone = TOP_CENTRE + [0.05, 0.05, CONTACT_LIFT[0]]
    heights = [_call(reward, 0, _limbs(right_foot=on_zone), com=np.array([0.0, 0.0, COM_HEIGHT[0] - d]))[1][3]
               for d in (0.0, 0.1, 0.2)]
    np.testing.assert_allclose(heights, np.exp(-50.0 * np.array([0.0, 0.1, 0.2]) ** 2))
    total, _ = _call(reward, 0, _limbs(right_foot=on_zone), com=np.array([0.0, 0.0, COM_HEIGHT[0]]))
    assert total == pytest.approx(0.5 + 0.2 + 0.3)
    flying = _call(reward, 2, _limbs(), com=np.array([0.0, 0.0, COM_HEIGHT[2]]))[1][3]
    assert flying == 0.0  # no limb on a box: in the air the ballistic r_com speaks instead
    np.testing.assert_allclose(reward.max_rewards, [1.0, 1.0, 0.3, 0.0])


def test_box_contacts_naming_a_missing_box_is_one_line():
    from actors.envs.imitation_env import EnvConfig, ImitationEnv
    from actors.arenas.scene import SceneError

    scenes = Path(__file__).resolve().parents[3] / "bench" / "scenes"
    motion = load_motion(str(scenes / "box_jump.npz"))
    motion.extras = {**motion.extras, "box_contacts": np.where(motion.extras["box_contacts"] >= 0, 1, -1)}
    with pytest.raises(SceneError, match=r"box_contacts names box 1 but the scene has 1 box"):
        ImitationEnv(motion, EnvConfig(scene=str(scenes / "box_jump_truth.yaml")))
