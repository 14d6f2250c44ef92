"""The residual root wrench (`actors/envs/residual_force.py`): six more action numbers, a force
and a torque in the root's frame, a reward that charges for them, and a report that says how
much the controller leaned on them."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.envs.residual_force import K, ResidualForce
from actors.motion.formats.io import load_motion


@pytest.fixture(scope="module")
def walk():
    return load_motion("deepmimic:walk")


def rollout_roots(env: ImitationEnv, action: np.ndarray, steps: int) -> np.ndarray:
    env.reset(seed=0, options={"init": "fsi"})
    roots = []
    for _ in range(steps):
        env.step(action)
        roots.append(env.data.qpos[:3].copy())
    return np.array(roots)


def test_a_zero_wrench_is_the_body_alone_and_an_upward_one_lifts_it(walk):
    plain = ImitationEnv(walk, EnvConfig())
    helped = ImitationEnv(walk, EnvConfig(residual_force=2.0))
    joints = plain.action_space.shape[0]
    assert helped.action_space.shape == (joints + 6,)
    alone = rollout_roots(plain, np.zeros(joints), 12)
    np.testing.assert_array_equal(rollout_roots(helped, np.zeros(joints + 6), 12), alone)
    up = np.zeros(joints + 6)
    up[joints + 2] = 1.0  # twice the body's weight along the root's z, up while the walker is upright: it flies
    lifted = rollout_roots(helped, up, 12)
    assert lifted[-1, 2] > alone[-1, 2] + 0.1
    np.testing.assert_allclose(helped.core.residual.force_fraction, [2.0])


def test_the_wrench_turns_with_the_root():
    model = mujoco.MjModel.from_xml_string("""<mujoco><worldbody><body name="b"><freejoint/>
        <geom type="box" size=".1 .1 .1" mass="2"/></body></worldbody></mujoco>""")
    data = mujoco.MjData(model)
    data.qpos[3:7] = [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]  # 90 degrees about z
    mujoco.mj_forward(model, data)
    ResidualForce.apply(data, 1, np.array([3.0, 0, 0, 0, 0, 2.0]))
    np.testing.assert_allclose(data.xfrc_applied[1], [0, 3.0, 0, 0, 0, 2.0], atol=1e-12)  # root x is world y; z stays z


def test_help_costs_reward_up_to_its_weight_and_scales_with_body_weight():
    residual = ResidualForce(0.5, 0.2, mass_kg=10.0, root_body=1, num_envs=3)
    residual.take(np.array([[0.0] * 6, [2.0, 0, 0, 0, 0, 0], [-1.0] * 6]))  # the second is clipped to 1
    np.testing.assert_allclose(residual.reward_factor(), [1.0, 0.8 + 0.2 * np.exp(-K), 0.8 + 0.2 * np.exp(-6 * K)])
    np.testing.assert_allclose(residual.local[1], [0.5 * 98.1, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(residual.local[2, 3:], [-0.5 * 98.1 * 0.5] * 3)
    np.testing.assert_allclose(residual.force_fraction, [0.0, 0.5, 0.5 * np.sqrt(3)])


@pytest.mark.parametrize("settings, word", [({"residual_force": -0.1}, "residual_force"),
                                             ({"residual_force": float("nan")}, "residual_force"),
                                             ({"residual_force_weight": 1.5}, "residual_force_weight")])
def test_bad_settings_are_errors_naming_the_field(settings, word):
    with pytest.raises(ValueError, match=word):
        EnvConfig(**settings)
