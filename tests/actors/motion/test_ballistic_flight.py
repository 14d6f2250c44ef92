"""Start states in a flight are ballistic: one angular momentum, the centre of mass falling at g,
the pose and the joints' own velocities the reference's."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from actors.envs.imitation_env import EnvConfig, ImitationEnv
from actors.motion.ballistic_flight import GRAVITY, TAKEOFF_MAX_ROWS, _takeoff_rows, ballistic_start_velocities, flight_stretches
from actors.motion.formats.io import load_motion


@pytest.fixture(scope="module")
def backflip_env():
    return ImitationEnv(load_motion("deepmimic:backflip"), EnvConfig(flight_starts="reference"))


def _momentum_and_com_velocity(model, qpos, qvel):
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_forward(model, data)
    mujoco.mj_subtreeVel(model, data)
    return data.subtree_angmom[1].copy(), data.subtree_linvel[1].copy()


def test_backflip_flight_gets_one_momentum_and_a_parabola(backflip_env):
    track, model = backflip_env.track, backflip_env.model
    qvel, report = ballistic_start_velocities(model, track.qpos, track.qvel, track.dt)
    first = report.flights[0]
    a, b = first.rows
    assert 0.3 < track.phase[a] < 0.45 and 0.6 < track.phase[b] < 0.75  # the flip's flight
    assert first.momentum_before[1] > 2 * first.momentum_before[0]  # the reference's is not constant
    before = [_momentum_and_com_velocity(model, track.qpos[k], track.qvel[k]) for k in range(a, b + 1)]
    after = [_momentum_and_com_velocity(model, track.qpos[k], qvel[k]) for k in range(a, b + 1)]
    momenta = np.array([m for m, _ in after])
    np.testing.assert_allclose(momenta, np.broadcast_to(momenta[0], momenta.shape), atol=1e-6)
    assert np.linalg.norm(momenta[0]) == pytest.approx(first.momentum_after, rel=1e-6)
    # Between the reference's smallest and largest momentum: a weighted mean, not a take-off's.
    assert first.momentum_before[0] < first.momentum_after < first.momentum_before[1]
    velocities = np.array([v for _, v in after])
    np.testing.assert_allclose(np.diff(velocities[:, 2]), -GRAVITY * track.dt, atol=1e-9)
    np.testing.assert_allclose(np.diff(velocities[:, :2], axis=0), 0.0, atol=1e-9)
    # Only the whole body's rigid motion changed: the joints move as the reference's do.
    np.testing.assert_array_equal(qvel[:, 6:], track.qvel[:, 6:])
    changed = np.flatnonzero(np.any(qvel != track.qvel, axis=1))
    in_flights = np.concatenate([np.arange(f.rows[0] - f.takeoff_rows, f.rows[1] + 1) for f in report.flights])
    assert set(changed) <= set(in_flights) and len(changed) > 0
    assert np.abs(np.array([m for m, _ in before])[:, 1]).max() > np.abs(momenta[0, 1]) + 10


def test_the_backflips_takeoff_rows_carry_the_flights_momentum_and_speed(backflip_env):
    """Rows 18-19 (phases .34-.36) touch the floor with the toes but sit on the flight's arc: a start
    there must already carry the flight's rotation, as no push is left to make it."""
    track, model = backflip_env.track, backflip_env.model
    qvel, report = ballistic_start_velocities(model, track.qpos, track.qvel, track.dt)
    first = report.flights[0]
    a = first.rows[0]
    assert 1 <= first.takeoff_rows <= TAKEOFF_MAX_ROWS
    takeoff = range(a - first.takeoff_rows, a)
    assert track.start_index(0.343) in takeoff
    for k in takeoff:
        before, _ = _momentum_and_com_velocity(model, track.qpos[k], track.qvel[k])
        after, velocity = _momentum_and_com_velocity(model, track.qpos[k], qvel[k])
        assert np.linalg.norm(before) < 0.6 * first.momentum_after  # the reference's take-off lags the flight
        assert np.linalg.norm(after) == pytest.approx(first.momentum_after, rel=1e-6)
        _, first_velocity = _momentum_and_com_velocity(model, track.qpos[a], qvel[a])
        assert velocity[2] == pytest.approx(first_velocity[2] + GRAVITY * track.dt * (a - k), abs=1e-6)  # on the parabola
    assert np.array_equal(qvel[a - first.takeoff_rows - 1], track.qvel[a - first.takeoff_rows - 1])  # the push itself is the reference's


def test_takeoff_rows_are_those_on_the_arc_counting_back_and_stop_at_the_first_off_it():
    dt, z0, vz0 = 1 / 30, 1.0, 2.0
    arc = lambda k: z0 + vz0 * (k * dt) - 0.5 * GRAVITY * (k * dt) ** 2  # noqa: E731
    z = np.array([arc(k - 10) for k in range(20)])
    assert _takeoff_rows(z, 10, vz0, z0, dt, 0.01, 0) == TAKEOFF_MAX_ROWS  # all on it: capped
    z[8] += 0.05  # two rows back is off the arc: only the row before counts
    assert _takeoff_rows(z, 10, vz0, z0, dt, 0.01, 0) == 1
    assert _takeoff_rows(z, 10, vz0, z0, dt, 0.1, 0) == TAKEOFF_MAX_ROWS  # a looser flight takes it in
    assert _takeoff_rows(z, 10, vz0, z0, dt, 0.1, 9) == 1  # never into the previous flight


def test_only_the_backflip_gets_takeoff_rows_among_the_seed_clips_with_flights():
    """The tolerance is the flight's own distance from its arc; the tight flights of the solved
    clips (jump, run, dance hops) keep the reference's take-off velocities."""
    for clip in ("deepmimic:jump", "deepmimic:run", "deepmimic:dance_b"):
        flights = ImitationEnv(load_motion(clip), EnvConfig()).track.flights.flights
        assert flights and all(f.takeoff_rows == 0 for f in flights), clip


def test_the_env_starts_from_ballistic_velocities_by_default():
    motion = load_motion("deepmimic:backflip")
    ballistic = ImitationEnv(motion, EnvConfig())
    reference = ImitationEnv(motion, EnvConfig(flight_starts="reference"))
    row = ballistic.track.start_index(0.5)
    ballistic.reset(options={"init": "rsi", "phase": 0.5})
    assert ballistic.track.flights.flights and not reference.track.flights.flights
    np.testing.assert_array_equal(ballistic.data.qvel, ballistic.track.qvel[row])
    assert not np.allclose(ballistic.track.qvel[row], reference.track.qvel[row])
    np.testing.assert_array_equal(ballistic.track.qpos, reference.track.qpos)
    np.testing.assert_array_equal(ballistic.track.features.values, reference.track.features.values)  # the reward's targets


def test_walk_has_no_flight_and_keeps_its_velocities():
    env = ImitationEnv(load_motion("deepmimic:walk"), EnvConfig(flight_starts="reference"))
    qvel, report = ballistic_start_velocities(env.model, env.track.qpos, env.track.qvel, env.track.dt)
    assert report.flights == []
    np.testing.assert_array_equal(qvel, env.track.qvel)


def test_hovering_feet_are_not_a_flight():
    dt = 1 / 30
    t = np.arange(10) * dt
    airborne = np.ones(10, bool)
    assert flight_stretches(airborne, 0.9 + 0.0 * t, dt) == []  # off the floor, not falling
    assert flight_stretches(airborne, 1.0 + 2.0 * t - 0.5 * GRAVITY * t ** 2, dt) == [(0, 10)]
    assert flight_stretches(np.array([0, 1, 1, 0] * 3, bool), np.zeros(12), dt) == []  # too short


def test_a_flight_behind_a_hovering_push_off_is_found_and_the_push_off_is_not():
    """A stretch that touches nothing from the crouch on, as the jump's reference: the centre of mass
    sinks 15 cm, rises under a push (+8 m/s^2, a ground force the hovering reference does not show),
    then flies under g."""
    dt = 1 / 30
    crouch = 0.85 - 0.075 * (1 - np.cos(np.pi * np.arange(16) / 15))
    push = np.arange(1, 11) * dt
    up = crouch[-1] + 4.0 * push ** 2
    fly = np.arange(1, 21) * dt
    z = np.concatenate([crouch, up, up[-1] + 8.0 * push[-1] * fly - 0.5 * GRAVITY * fly ** 2])
    airborne = np.ones(len(z), bool)
    assert -GRAVITY / 2 < 2 * np.polyfit(np.arange(len(z)) * dt, z, 2)[0]  # the whole stretch is no flight
    ((a, b),) = flight_stretches(airborne, z, dt)
    assert b == len(z) and 24 <= a <= 27  # the flight, from about the last push row (25)
    assert flight_stretches(airborne[:26], z[:26], dt) == []  # crouch and push alone: none
    # A window shorter than 0.2 s that happens to fall at g is noise, not a flight.
    wiggle = np.full(12, 0.8)
    wiggle[4:9] = 0.8 + 0.5 * GRAVITY * (np.arange(5) * dt) * (4 * dt - np.arange(5) * dt)
    assert flight_stretches(np.ones(12, bool), wiggle, dt) == []


def test_the_jump_and_dance_b_flights_are_found():
    for clip, flight in (("deepmimic:jump", (22, 37)), ("deepmimic:dance_b", (12, 18))):
        env = ImitationEnv(load_motion(clip), EnvConfig())
        rows = [f.rows for f in env.track.flights.flights]
        assert flight in rows, (clip, rows)
