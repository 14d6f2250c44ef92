"""The scene reward of the dynamic-camera paper (002 section 5.1, eq. 10-12), for B envs at once.

    r_scene  = 0.5 r_dist + 0.2 r_align + 0.3 r_com + 0.3 r_height
    r_dist   = c exp(-15 sum_l |mindist(Z_l, p_l)|^2)        l in {rf, lf, rh, lh} touching a box
    r_align  = c exp(-1 (1 - u_pelvis . u_obj)^2)
    r_com    = exp(-5 |d_ee - d_obj|^2)                       while in the air, landing on a box
    r_height = c exp(-50 (z_com - z*_com)^2)                  ours, not 002's: see below

c is 1 on the reference frames where a hand or foot touches a box. Contact zones Z_l lie on
the box's top face: the feet's is the centred quarter of its area (002 Fig. 7, half its
length and half its width); the hands' are the near corners (002: "we manually set Z_rh and
Z_lh to the corner of the object"), here the square of a quarter length and width at the
right (left) near corner. p_l is the limb's contact point: the ankle's sole, the wrist's
sphere bottom (the link origin lowered by `CONTACT_LIFT`).

Which limb touches which box on which frame (`SceneContacts.of_track`): the motion's
`box_contacts` extra (T, 4) int, box index or -1 per limb in `SCENE_LIMBS` order, when the
file has it (hand contacts are "manually given" in 002 too); otherwise the feet are on a box
where the reference sole rests within `TOP_BAND` of its (nominal) top face, inside its
footprint unless the clip is root-free, and, if the file has `contacts` (the foot-contact
estimator's flags), only where the flag is on. "In the air" is the reference's: no limb
in contact by the same rule.

Deviations: u_obj is the box's front axis, the clip's initial heading (002 leaves "the
object's direction" open; our boxes face the start). Eq. 12's d_ee and d_obj are distances;
here they are vectors, the landing limb's offset from the centre of mass in the reference
pose at landing against the ballistic prediction of the simulated centre of mass at the
estimated landing time minus the zone: the landing point nearest the zone, so a lengths-only
match anywhere on a sphere does not pay. r_com uses the reference's flight (frames without
contact), not the simulated one's, so the table is precomputed per reference row.

Deviation, r_height (not in 002): while a limb rests on a box, the centre of mass's height
against the reference's. Without it eq. 14 has no maximum at the true box when the motion
is root-free: a box flush with the floor pays r_dist in full (the foot on the floor is on
its top face), r_com likewise (the ballistic landing point lies on it), and the joint terms
do not see the root, so the easiest scene wins. Measured on the synthetic box jump (truth
along 1.1 m, height 0.2 m; 1.8 M samples): the fit went to the domain's corner (0.9, 0.0),
and the value landscape fell monotonically with height. The root-free reference keeps its
height (the ground and the up direction fix it; `movingcam_termination.py` uses it too), and
that height is what says how high the person stood: on a box too low the character stands
lower than the reference by the difference for as long as it stays on it. `w_height` 0
restores 002's three terms.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from actors.character.kinematics import forward_kinematics
from actors.motion.formats.io import root_is_free
from actors.arenas.scene import Scene, SceneError, SceneFrame
from actors.character.skeleton import LINK_NAMES, LINKS

SCENE_LIMBS = ("right_ankle", "left_ankle", "right_wrist", "left_wrist")  # 002's rf, lf, rh, lh
SCENE_CHARACTERS = ("humanoid3d",)  # the bodies whose links SCENE_LIMBS names
SCENE_LIMB_LINKS = np.array([LINK_NAMES.index(n) for n in SCENE_LIMBS])
NUM_TERMS = 4  # dist, align, com, height
TOP_BAND = 0.04  # m: a reference sole this close to a top face rests on it
FOOTPRINT_MARGIN = 0.05  # m around a box's footprint
GRAVITY = np.array([0.0, 0.0, -9.81])


def _contact_lift(name: str) -> float:
    """Height of a limb's link origin above the surface it rests on (foot flat; wrist sphere)."""
    link = LINKS[LINK_NAMES.index(name)]
    if link.shape == "box":  # the foot: geom centre y-offset (Y-up) minus half its height
        return float(-(link.geom_offset_yup[1] - link.size[1] / 2))
    return float(link.size[0])


CONTACT_LIFT = np.array([_contact_lift(n) for n in SCENE_LIMBS])  # (4,)


@dataclass(frozen=True)
class SceneRewardConfig:
    w_dist: float = 0.5
    w_align: float = 0.2
    w_com: float = 0.3
    alpha_dist: float = 15.0
    alpha_align: float = 1.0
    alpha_com: float = 5.0
    w_height: float = 0.3
    alpha_height: float = 50.0  # per m^2: .61 at 10 cm, .14 at 20 cm

    @property
    def max_reward(self) -> float:
        """The most r_scene pays in one step (a step that touches or flies to a box)."""
        return self.w_dist + self.w_align + self.w_com + self.w_height

    @property
    def weights(self) -> np.ndarray:
        return np.array([self.w_dist, self.w_align, self.w_com, self.w_height])


def contact_zones(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Per box and limb, the zone's centre offset from the top face's centre (along, lateral)
    and its half extents: (K, 4, 2) each."""
    size = np.array([b.size for b in scene.boxes], dtype=np.float64)  # (K, 2) length, width
    centre = np.zeros((scene.num_boxes, 4, 2))
    half = np.repeat(size[:, None, :] / 4.0, 4, axis=1)  # feet: the centred quarter of the area
    for limb, side in ((2, -1.0), (3, 1.0)):  # hands: a near corner, right = -lateral
        centre[:, limb] = np.stack((-3.0 * size[:, 0] / 8.0, side * 3.0 * size[:, 1] / 8.0), axis=1)
        half[:, limb] = size / 8.0
    return centre, half


@dataclass
class SceneContacts:
    """Per reference row: the box each limb touches (-1 none), and for rows in the air before
    a landing on a box: that box, the landing limb, the time to landing and d_ee."""

    target: np.ndarray  # (R, 4) int
    air_box: np.ndarray  # (R,) int, -1 unless in the air before landing on a box
    air_limb: np.ndarray  # (R,) int
    air_time: np.ndarray  # (R,) s
    air_offset: np.ndarray  # (R, 3): reference centre of mass minus the landing contact point, at landing
    com_height: np.ndarray  # (R,) the reference's centre-of-mass height

    @classmethod
    def of_track(cls, track, scene: Scene, frame: SceneFrame) -> "SceneContacts":
        motion = track.motion
        frames = _frame_of_rows(motion, track.times)
        poses = motion.sample(track.times)
        links, _ = forward_kinematics(poses.root_pos, poses.root_rot, poses.joint_rot)
        points = links[:, SCENE_LIMB_LINKS] - np.array([0.0, 0.0, 1.0]) * CONTACT_LIFT[:, None]  # (R, 4, 3)
        if "box_contacts" in motion.extras:
            target = _box_contacts(motion, scene)[frames]
            touching = target >= 0
            touching[:, :2] |= _feet_down(motion, frames, points)
        else:
            target, touching = _feet_on_boxes(motion, frames, points, scene, frame)
        return cls(target, *_flights(track.times, touching, target, track.com, points), np.asarray(track.com)[:, 2].copy())

    @property
    def active(self) -> np.ndarray:
        return self.target >= 0


def _box_contacts(motion, scene: Scene) -> np.ndarray:
    """The motion's `box_contacts`, checked against its frames and the scene's boxes."""
    table = np.asarray(motion.extras["box_contacts"])
    if table.shape != (motion.num_frames, len(SCENE_LIMBS)) or not np.issubdtype(table.dtype, np.integer):
        raise SceneError(f"{motion.name}: box_contacts must be ({motion.num_frames}, 4) integers (box index or -1 per "
                         f"{', '.join(SCENE_LIMBS)}), got {table.dtype} {table.shape}")
    if table.size and not -1 <= table.min() <= table.max() < scene.num_boxes:
        raise SceneError(f"{motion.name}: box_contacts names box {int(table.max())} but the scene has {scene.num_boxes} "
                         f"box(es) (indices 0..{scene.num_boxes - 1}, -1 for none)")
    return table.astype(np.int64)


def _frame_of_rows(motion, times: np.ndarray) -> np.ndarray:
    local = np.mod(times, motion.duration) if motion.loop else np.clip(times, 0.0, motion.duration)
    i = np.clip(np.searchsorted(motion.frame_times, local), 1, motion.num_frames - 1)
    earlier = (local - motion.frame_times[i - 1]) < (motion.frame_times[i] - local)
    return np.where(earlier, i - 1, i)


def _feet_on_boxes(motion, frames, points, scene: Scene, frame: SceneFrame):
    """(target, touching) from the reference feet (module docstring's rule)."""
    rows = len(frames)
    target = np.full((rows, 4), -1, dtype=np.int64)
    feet = points[:, :2]  # (R, 2, 3)
    heights = feet[..., 2]
    flags = np.asarray(motion.extras["contacts"], bool)[frames] if "contacts" in motion.extras else None
    touching = _feet_down(motion, frames, points)
    plan = frame.to_scene(feet[..., :2])  # (R, 2, 2)
    check_footprint = not root_is_free(motion)
    for k, box in enumerate(scene.boxes):
        on_top = np.abs(heights - box.height) < TOP_BAND
        on_top &= box.height > TOP_BAND  # a box flush with the floor is the floor
        if check_footprint:
            on_top &= np.abs(plan[..., 0] - box.along) < box.size[0] / 2 + FOOTPRINT_MARGIN
            on_top &= np.abs(plan[..., 1] - box.lateral) < box.size[1] / 2 + FOOTPRINT_MARGIN
        if flags is not None:
            on_top &= flags
        target[:, :2][on_top & (target[:, :2] < 0)] = k
        if flags is None:
            touching |= on_top
    return target, np.concatenate((touching, np.zeros((rows, 2), bool)), axis=1)


def _feet_down(motion, frames, points) -> np.ndarray:
    """(R, 2) feet on anything: the `contacts` extra where the file has it, else the
    reference sole within TOP_BAND of the floor (box tops are added by the caller)."""
    if "contacts" in motion.extras:
        return np.asarray(motion.extras["contacts"], bool)[frames]
    return points[:, :2, 2] < TOP_BAND


def _flights(times, touching, target, com, points):
    """For each row with no limb touching anything, the next landing if it is on a box."""
    rows = len(times)
    air_box = np.full(rows, -1, dtype=np.int64)
    air_limb = np.zeros(rows, dtype=np.int64)
    air_time = np.zeros(rows)
    air_offset = np.zeros((rows, 3))
    landing = None
    for r in range(rows - 1, -1, -1):  # backwards: the next landing is known when a flight row is met
        if touching[r].any():
            limbs = np.flatnonzero(target[r] >= 0)
            landing = (r, limbs[0]) if limbs.size else None
            continue
        if landing is not None:
            row, limb = landing
            air_box[r], air_limb[r] = target[row, limb], limb
            air_time[r] = times[row] - times[r]
            air_offset[r] = com[row] - points[row, limb]
    return air_box, air_limb, air_time, air_offset


class SceneReward:
    """Eq. 10-12 for B envs, each with its own scene vector e."""

    def __init__(self, scene: Scene, frame: SceneFrame, contacts: SceneContacts, config: SceneRewardConfig = SceneRewardConfig()):
        self.config = config
        self.frame = frame
        self.contacts = contacts
        self.lateral = np.array([b.lateral for b in scene.boxes])
        self.zone_centre, self.zone_half = contact_zones(scene)
        forward = frame.forward
        self.u_obj = np.array([forward[0], forward[1], 0.0])
        self._weights = config.weights
        c = config
        self.max_rewards = (c.w_dist + c.w_align + c.w_height) * contacts.active.any(axis=1) + c.w_com * (contacts.air_box >= 0)

    @classmethod
    def for_track(cls, track, scene: Scene, frame: SceneFrame, config: SceneRewardConfig = SceneRewardConfig()) -> "SceneReward":
        return cls(scene, frame, SceneContacts.of_track(track, scene, frame), config)

    def zone_distance(self, boxes: np.ndarray, limbs: np.ndarray, points: np.ndarray, e: np.ndarray) -> np.ndarray:
        """(N, 3) from each point (world) to the zone of limb `limbs[n]` on box `boxes[n]` at
        the scene vector e[n] (2K,): along, lateral and height gaps (0 inside the zone)."""
        scene_xy = self.frame.to_scene(points[:, :2])
        along = np.take_along_axis(e, 2 * boxes[:, None], axis=1)[:, 0]
        top = np.take_along_axis(e, 2 * boxes[:, None] + 1, axis=1)[:, 0]
        centre = np.stack((along, self.lateral[boxes]), axis=1) + self.zone_centre[boxes, limbs]
        gap = np.maximum(np.abs(scene_xy - centre) - self.zone_half[boxes, limbs], 0.0)
        return np.concatenate((gap, (points[:, 2] - CONTACT_LIFT[limbs] - top)[:, None]), axis=1)

    def batch(self, rows: np.ndarray, limb_pos: np.ndarray, pelvis_front: np.ndarray, com: np.ndarray,
              com_vel: np.ndarray, e: np.ndarray, terms: np.ndarray | None = None) -> np.ndarray:
        """(B,) r_scene. rows (B,) reference rows; limb_pos (B, 4, 3) world link origins of
        SCENE_LIMBS; pelvis_front (B, 3) the root's +x axis; com, com_vel (B, 3); e (B, 2K).
        `terms` (B, 4), if given, receives r_dist, r_align, r_com, r_height."""
        c, contacts = self.config, self.contacts
        b = len(rows)
        out_terms = np.zeros((b, NUM_TERMS)) if terms is None else terms
        out_terms[:] = 0.0
        target = contacts.target[rows]  # (B, 4)
        env_i, limb_i = np.nonzero(target >= 0)
        if env_i.size:
            gap = self.zone_distance(target[env_i, limb_i], limb_i, limb_pos[env_i, limb_i], e[env_i])
            squared = np.zeros(b)
            np.add.at(squared, env_i, np.einsum("ij,ij->i", gap, gap))
            touching = target.max(axis=1) >= 0
            out_terms[:, 0] = touching * np.exp(-c.alpha_dist * squared)
            out_terms[:, 1] = touching * np.exp(-c.alpha_align * (1.0 - pelvis_front @ self.u_obj) ** 2)
            if c.w_height:
                out_terms[:, 3] = touching * np.exp(-c.alpha_height * (com[:, 2] - contacts.com_height[rows]) ** 2)
        box = contacts.air_box[rows]
        flying = np.flatnonzero(box >= 0)
        if flying.size:
            r = rows[flying]
            tau = contacts.air_time[r][:, None]
            predicted = com[flying] + com_vel[flying] * tau + 0.5 * GRAVITY * tau ** 2 - contacts.air_offset[r]
            gap = self.zone_distance(box[flying], contacts.air_limb[r], predicted + CONTACT_LIFT[contacts.air_limb[r], None] * [0, 0, 1], e[flying])
            out_terms[flying, 2] = np.exp(-c.alpha_com * np.einsum("ij,ij->i", gap, gap))
        return out_terms @ self._weights
