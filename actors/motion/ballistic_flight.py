"""Start states in a clip's flight made ballistic: one angular momentum and a parabola per flight.

Once nothing touches the ground, physics keeps the body's angular momentum about its centre of
mass constant and drops the centre of mass at g. A reference's kinematic velocities need not: on
our humanoid the backflip's flight (phases .38-.67) carries 25 -> 66 -> 24 kg m^2/s
(`bench/scripts/flight_momentum.py`), so an episode started mid-flight from the reference's
velocities spins 2.6x faster than any take-off can make it, and no action changes that in the air.
Five of the backflip's six `sfv eval` falls at 14 M samples started there (phases .34-.50). That
policy trained 3 M samples more with ballistic starts: `sfv eval` (itself ballistic) .694 with 6 / 32
falls -> .759 with 4, no fall left that starts mid-flight
(`bench/results/acrobatics/eval_backflip_ballistic_ft.json`).

Each flight (rows whose reference pose touches nothing, at least `MIN_FLIGHT_ROWS` long, whose
centre of mass falls at more than half of g: a stretch that does not is feet hovering over the
floor, not a flight; or, inside such a stretch, the longest window of at least 0.2 s whose centre
of mass follows g within 10 % and a parabola within 0.5 cm: the jump's flight behind its hovering
push-off, `flight_stretches`) gets, for start states only:
- one angular momentum L* = (sum_k I_k^-1)^-1 sum_k I_k^-1 L_k, with I_k the whole body's inertia
  about its centre of mass in row k's pose: the constant momentum whose rotation rate, summed over
  the flight's poses, turns the body as far as the reference's does (a least-squares fit of the
  angular velocities). Measured on the backflip: L* = 41.1 kg m^2/s, and the policy trained to 14 M
  samples from the reference's velocities carries 39.9-41.6 through its own flight from the clip's
  first frame (`bench/scripts/flight_momentum.py --run`): the momentum a take-off gives;
- the centre of mass's velocity on the parabola under g that fits the reference's centre of mass
  positions best.
The take-off rows just before a flight join it (`takeoff_rows`): up to TAKEOFF_MAX_ROWS rows whose
centre of mass lies as close to the flight's parabola carried back as the flight's own rows lie to
it, stopping at the first that does not. The backflip's rows 18-19 (phases .34-.36) are such rows:
the toes still touch but the centre of mass is 2.6 and 0.7 cm off the arc (its flight rows up to
about 3 cm; row 17, still pushing, 7 cm), and the reference carries 18-19 kg m^2/s and
1.3-1.6 m/s upwards there, against the 37-40 kg m^2/s and 2.2 m/s the trained policy has at the same
phase from the first frame. A start there is in the air one step later with half the rotation: at
20 M samples the start at .343 was one of `sfv eval`'s three falls (on its back at the landing, .648)
while the starts at .305 and .381 on either side scored .83-.84. With these rows ballistic the
start gets the flight's momentum and take-off speed. Landing rows stay the reference's: there
contact is what takes the momentum away.

A row's velocities change only by a rigid-body rotation and translation of the whole body (the
root's angular and linear velocity; joint velocities keep theirs), so its pose and limb motion are
the reference's. The reward still compares against the reference's own velocities. DeepMimic and
SFV start from the reference's velocities as they are; this is ours, and `EnvConfig.flight_starts`
= "reference" turns it off.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

MIN_FLIGHT_ROWS = 3
# A flight inside a longer airborne stretch: at least 0.2 s (6 control steps) whose centre of mass
# follows g within 10 % and fits a parabola within FLIGHT_FIT_M. Shorter windows fit noise: over the 15 DeepMimic clips, 3-5-row windows
# within 10 % of g turned up in the crawl and the roll, which never leave the floor.
MIN_FLIGHT_SECONDS = 0.2
FLIGHT_G_TOLERANCE = 0.1
FLIGHT_FIT_M = 0.005  # rms of the fit: the jump's flight 0.4 cm, dance_b's hops 0.07 cm
GRAVITY = 9.81
# Take-off rows joining a flight: at most 0.1 s before it.
TAKEOFF_MAX_ROWS = 3


@dataclass
class Flight:
    rows: tuple[int, int]  # [first, last] airborne rows
    momentum_before: tuple[float, float]  # smallest and largest |L| of the reference's rows (kg m^2/s)
    momentum_after: float  # |L*|
    com_vertical_acceleration: float  # the reference's fitted CoM acceleration (physics: -9.81)
    root_angular_velocity_change: float  # the largest |delta omega| applied to a row (rad/s)
    takeoff_rows: int = 0  # rows before rows[0] made ballistic too (take-off on the flight's arc)


@dataclass
class FlightReport:
    flights: list[Flight] = field(default_factory=list)


class _RowKinematics:
    """Per-row centre of mass, its velocity, angular momentum about it, and the whole-body inertia."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self.data = mujoco.MjData(model)

    def measure(self, qpos: np.ndarray, qvel: np.ndarray) -> tuple[bool, np.ndarray, np.ndarray, np.ndarray]:
        d = self.data
        d.qpos[:] = qpos
        d.qvel[:] = qvel
        mujoco.mj_forward(self.model, d)
        mujoco.mj_subtreeVel(self.model, d)
        return d.ncon == 0, d.subtree_com[1].copy(), d.subtree_linvel[1].copy(), d.subtree_angmom[1].copy()

    def rigid_basis(self, qpos: np.ndarray, com: np.ndarray) -> np.ndarray:
        """(6, nv): the qvel changes that turn the whole body at unit world angular velocity about
        its centre of mass (rows 0-2) and move it at unit world velocity (rows 3-5)."""
        basis = np.zeros((6, self.model.nv))
        quat = qpos[3:7]
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, quat)
        rot = rot.reshape(3, 3)  # body-to-world: free-joint angular velocity is in the body frame
        lever = com - qpos[:3]
        for i in range(3):
            w = np.eye(3)[i]
            basis[i, 3:6] = rot.T @ w
            basis[i, 0:3] = -np.cross(w, lever)  # keeps the centre of mass where it is going
            basis[3 + i, i] = 1.0
        return basis

    def inertia(self, qpos: np.ndarray, qvel: np.ndarray, com: np.ndarray, momentum: np.ndarray) -> np.ndarray:
        """3x3 whole-body inertia about the centre of mass, by the momentum's linear response."""
        basis = self.rigid_basis(qpos, com)
        columns = [self.measure(qpos, qvel + basis[i])[3] - momentum for i in range(3)]
        return np.stack(columns, axis=1)


def flight_stretches(airborne: np.ndarray, com_z: np.ndarray, dt: float) -> list[tuple[int, int]]:
    """[a, b) row ranges that are flights. An airborne stretch (the reference pose touches nothing)
    of MIN_FLIGHT_ROWS rows or more is one when its centre of mass falls at more than g / 2 over
    the whole stretch. One that does not can still hold a flight behind a hovering push-off or
    before a hovering landing: the jump's reference touches nothing from its crouch to its landing
    (rows 11-37: the feet 0-3 cm above the floor while the centre of mass drops 13 cm and rises
    again, then 0.5 s in the air), so the whole stretch fits an upward acceleration of -0.9 m/s^2.
    Its flight is the longest window of at least MIN_FLIGHT_SECONDS whose centre of mass follows g
    within FLIGHT_G_TOLERANCE and a parabola within FLIGHT_FIT_M (the jump: rows 22-37, -9.4 m/s^2,
    0.4 cm); the rest of the stretch keeps
    the reference's velocities. Leftovers on either side are searched the same way."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], airborne.astype(int), [0]))))
    out: list[tuple[int, int]] = []
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a < MIN_FLIGHT_ROWS:
            continue
        if _fitted_acceleration(com_z[a:b], dt) < -GRAVITY / 2:
            out.append((int(a), int(b)))
        else:
            _ballistic_windows(com_z, int(a), int(b), dt, max(MIN_FLIGHT_ROWS, int(np.ceil(MIN_FLIGHT_SECONDS / dt - 1e-9))), out)
    return sorted(out)


def _fitted_acceleration(z: np.ndarray, dt: float) -> float:
    return 2.0 * float(np.polyfit(np.arange(len(z)) * dt, z, 2)[0])


def _is_ballistic(z: np.ndarray, dt: float) -> bool:
    """The centre of mass heights fit a parabola whose acceleration is g within the tolerance, and
    closely (push rows bend the curve: the jump's window 20-37 fits -8.4 m/s^2 off by 1.7 cm rms)."""
    t = np.arange(len(z)) * dt
    coeffs = np.polyfit(t, z, 2)
    residual = float(np.sqrt(np.mean((z - np.polyval(coeffs, t)) ** 2)))
    return abs(2.0 * coeffs[0] + GRAVITY) <= FLIGHT_G_TOLERANCE * GRAVITY and residual <= FLIGHT_FIT_M


def _ballistic_windows(com_z: np.ndarray, a: int, b: int, dt: float, shortest: int, out: list) -> None:
    """Append the longest window of [a, b) whose centre of mass falls at g, then search what is left."""
    for length in range(b - a, shortest - 1, -1):
        for start in range(a, b - length + 1):
            if _is_ballistic(com_z[start:start + length], dt):
                out.append((start, start + length))
                _ballistic_windows(com_z, a, start, dt, shortest, out)
                _ballistic_windows(com_z, start + length, b, dt, shortest, out)
                return


def ballistic_start_velocities(model: mujoco.MjModel, qpos: np.ndarray, qvel: np.ndarray, dt: float) -> tuple[np.ndarray, FlightReport]:
    """`qvel` (rows, nv) with each flight's rows made ballistic (see the module docstring);
    rows outside flights are returned unchanged."""
    rows = len(qpos)
    kin = _RowKinematics(model)
    measured = [kin.measure(qpos[k], qvel[k]) for k in range(rows)]
    airborne = np.array([m[0] for m in measured])
    com = np.array([m[1] for m in measured])
    out = qvel.copy()
    report = FlightReport()
    for a, b in flight_stretches(airborne, com[:, 2], dt):
        t = np.arange(b - a) * dt
        # The parabola under g through the reference's centre of mass: z - (-g t^2 / 2) is linear in t.
        lift = com[a:b].copy()
        lift[:, 2] += 0.5 * GRAVITY * t ** 2
        slope, intercept = np.polyfit(t, lift, 1)
        tolerance = float(np.abs(com[a:b, 2] - _arc(intercept[2], slope[2], t)).max())  # the flight's own distance
        takeoff = _takeoff_rows(com[:, 2], a, slope[2], intercept[2], dt, tolerance,
                                report.flights[-1].rows[1] + 1 if report.flights else 0)
        first = a - takeoff
        inverse = [np.linalg.inv(kin.inertia(qpos[k], qvel[k], com[k], measured[k][3])) for k in range(first, b)]
        flight = inverse[takeoff:]  # L* is fitted on the flight's rows only
        target = np.linalg.solve(sum(flight), sum(inv @ measured[k][3] for inv, k in zip(flight, range(a, b))))
        largest = 0.0
        for j, k in enumerate(range(first, b)):
            d_omega = inverse[j] @ (target - measured[k][3])
            velocity = slope - np.array([0.0, 0.0, GRAVITY * (k - a) * dt])
            basis = kin.rigid_basis(qpos[k], com[k])
            out[k] = qvel[k] + d_omega @ basis[:3] + (velocity - measured[k][2]) @ basis[3:]
            largest = max(largest, float(np.linalg.norm(d_omega)))
        norms = [float(np.linalg.norm(measured[k][3])) for k in range(a, b)]
        accel = 2.0 * float(np.polyfit(t, com[a:b, 2], 2)[0])
        report.flights.append(Flight((a, b - 1), (min(norms), max(norms)), float(np.linalg.norm(target)), accel, largest, takeoff))
    return out, report


def _arc(z0: float, vz0: float, t):
    """Height on the flight's parabola under g at time t from its first row."""
    return z0 + vz0 * t - 0.5 * GRAVITY * t * t


def _takeoff_rows(com_z: np.ndarray, a: int, vz0: float, z0: float, dt: float, tolerance: float, floor: int) -> int:
    """How many rows just before row `a` (not below row `floor`, the previous flight's end) have
    their centre of mass on the flight's parabola z0 + vz0 t - g t^2 / 2 (t from row a) within
    `tolerance`, counting back from a and stopping at the first that is not."""
    count = 0
    while count < TAKEOFF_MAX_ROWS and a - count - 1 >= floor:
        t = -(count + 1) * dt
        if abs(com_z[a - count - 1] - _arc(z0, vz0, t)) > tolerance:
            break
        count += 1
    return count
