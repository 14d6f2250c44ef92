"""Left/right mirroring of a character: states, actions, observations and whole clips.

NPMP (004 §3.2-3.3) distils one expert per clip; mirrored clips double the data for free
when the body is symmetric. Every map here reads the character's mirror maps (`link_mirror`,
`joint_mirror`, `joint_mirror_sign`) and joint kinds. Both bodies face +x with their right side
at -y and Z up, so their sagittal plane is the world's x-z plane: humanoid3d (the frame of
`skeleton.py`) has every left link its right partner's reflection in it (offsets, geoms, masses,
gains) and the joint limits reflect into each other (`tests/actors/character/test_mirror.py`); the
Unitree G1's MJCF is symmetric to 1e-5 m (`tests/actors/character/test_g1_mirror.py`). The
reflection S = diag(1, -1, 1) acts on
- positions and linear velocities (polar vectors): (x, y, z) -> (x, -y, z);
- rotations R -> S R S, i.e. quaternions (w, x, y, z) -> (w, -x, y, -z), and rotation vectors
  or angular velocities (axial vectors) -> (-x, y, -z);
- hinges: S R(a, theta) S = R(-S a, theta), so a hinge's mirrored angle is its partner's times
  `joint_mirror_sign`: +1 when the partner's axis is -S a (humanoid3d's knees and elbows, axis
  (0, -1, 0) in the plane; the G1's pitch hinges, knees and elbows), -1 when it is S a (the G1's
  roll and yaw hinges). `symmetry.derive_hinge_mirror_signs` reads them off the compiled model (world
  axes at the zero pose) and `state_mirror` / `observation_mirror` check the declared ones
  against it;
and swaps each left link with its right partner. Every map here is a signed permutation of
the numbers it acts on, so it is exact, linear and its own inverse (an involution).

The observation of `FeatureExtractor` is built in the root's heading frame, whose yaw is
mirrored too (theta -> -theta), so the observation of a mirrored state is the signed
permutation of the original's observation (`ObservationMirror`): a policy trained on a clip
can act on the mirrored clip by reading the mirrored observation back, with no MjData.
"""
from __future__ import annotations

import numpy as np

from actors.character.features import REFERENCE_OBS_WIDTH, obs_dim, pose_obs_width
from actors.character.humanoid3d import HUMANOID3D
from actors.character.symmetry import POLAR, check_mirror_signs, mirror_signs

MIRROR_SUFFIX = "_mirror"
AXIAL = np.array([-1.0, 1.0, -1.0])  # rotation vectors, angular velocities
QUAT = np.array([1.0, -1.0, 1.0, -1.0])  # (w, x, y, z) of S R S


def mirrored_name(name: str, character: str | None = None) -> str:
    """'walk' -> 'walk_mirror' and back (mirroring twice is the original). With `character`, a
    name ending in `_<character>` (a clip retargeted onto that body) keeps its suffix last, as
    the retargeting of a mirrored clip names it: 'deepmimic:walk_g1' <-> 'deepmimic:walk_mirror_g1'."""
    body = f"_{character}" if character else ""
    if body and name.endswith(body) and len(name) > len(body):
        return mirrored_name(name[: -len(body)]) + body
    return name[: -len(MIRROR_SUFFIX)] if name.endswith(MIRROR_SUFFIX) else name + MIRROR_SUFFIX


class SignedPermutation:
    """y = sign * x[..., source]: one mirror map on the last axis of a batch."""

    def __init__(self, source: np.ndarray, sign: np.ndarray):
        self.source = np.asarray(source, dtype=np.int64)
        self.sign = np.asarray(sign, dtype=np.float64)
        if sorted(self.source.tolist()) != list(range(len(self.source))):
            raise ValueError("internal: a mirror map must be a permutation")

    def __call__(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        x = np.asarray(x)
        result = np.take(x, self.source, axis=-1)
        result *= self.sign.astype(result.dtype, copy=False)
        if out is None:
            return result
        np.copyto(out, result)
        return out

    @classmethod
    def from_blocks(cls, size: int, blocks: list[tuple[int, int, np.ndarray]]) -> "SignedPermutation":
        """Blocks (source start, destination start, signs): destination[d + k] = signs[k] *
        source[s + k]; entries no block names stay put with sign +1."""
        source, sign = np.arange(size), np.ones(size)
        for start, dest, signs in blocks:
            width = len(signs)
            source[dest:dest + width] = np.arange(start, start + width)
            sign[dest:dest + width] = signs
        return cls(source, sign)


def can_mirror(character) -> bool:
    """Whether the character declares its mirror maps and hinge mirror signs."""
    return all(getattr(character, key, None) is not None for key in ("link_mirror", "joint_mirror", "joint_mirror_sign"))


def state_mirror(humanoid) -> tuple[SignedPermutation, SignedPermutation]:
    """(qpos map, qvel map) of MuJoCo's state vectors for this built character's joint
    addresses: the root reflected, ball joints as quaternions / axial vectors, hinges their
    partner's angle and rate times the joint's mirror sign (checked against the model)."""
    qadr, dadr = humanoid.joint_qpos_adr, humanoid.joint_dof_adr
    character = humanoid.character
    signs = check_mirror_signs(humanoid)
    qpos_blocks = [(0, 0, POLAR), (3, 3, QUAT)]
    qvel_blocks = [(0, 0, POLAR), (3, 3, AXIAL)]
    for j, ball in enumerate(character.joint_is_spherical):
        p = character.joint_mirror[j]
        qpos_blocks.append((qadr[j], qadr[p], QUAT if ball else signs[j:j + 1]))
        qvel_blocks.append((dadr[j], dadr[p], AXIAL if ball else signs[j:j + 1]))
    return SignedPermutation.from_blocks(humanoid.nq, qpos_blocks), SignedPermutation.from_blocks(humanoid.nv, qvel_blocks)


def action_mirror(parameterisation: str = "exp_map", character=HUMANOID3D) -> SignedPermutation:
    """Map of the policy's action vector (`actions.py` layout: the spherical joints, then
    the revolute). exp_map: a rotation vector per ball joint (axial); axis_angle: (angle,
    axis), the angle kept and the axis axial. With exp_map (nu entries) this is also the map
    of the PD targets (MuJoCo ctrl / actuator lengths). A hinge's entry is its partner's times
    the joint's mirror sign. The per-axis action scales and joint limits of partners mirror into
    each other (reflected by the sign), so scaling and clipping commute with it."""
    width, signs = (4, np.concatenate(([1.0], AXIAL))) if parameterisation == "axis_angle" else (3, AXIAL)
    balls = np.flatnonzero(character.joint_is_spherical).tolist()
    hinges = np.flatnonzero(~character.joint_is_spherical).tolist()
    partner, hinge_sign = character.joint_mirror, mirror_signs(character)
    blocks = [(width * s, width * balls.index(partner[j]), signs) for s, j in enumerate(balls)]
    base = width * len(balls)
    blocks += [(base + r, base + hinges.index(partner[j]), hinge_sign[j:j + 1]) for r, j in enumerate(hinges)]
    return SignedPermutation.from_blocks(base + len(hinges), blocks)


def observation_mirror(humanoid, reference_steps: int, pose_steps: int = 0) -> SignedPermutation:
    """Map of `FeatureExtractor.observations` (height, link positions, rotations, linear
    and angular velocities in the heading frame, K reference roots, phase), followed by
    `pose_steps` reference poses (`actors/envs/reference_obs.py`: height, link positions). Links
    there are in MuJoCo body order (bodies 1..n), not skeleton order. Hinge angles are not
    observed (link rotations are), but the character's mirror signs are checked against its
    model here too: the map is right only for a body that is its own mirror image."""
    character = humanoid.character
    check_mirror_signs(humanoid)
    body_row = humanoid.body_ids - 1  # skeleton link -> its row in the observation's link blocks
    n, k = character.num_links, int(reference_steps)
    row_partner = np.empty(n, dtype=np.int64)
    row_partner[body_row] = body_row[character.link_mirror]
    pos, rot = 1, 1 + 3 * n
    lin, ang = rot + 4 * n, rot + 4 * n + 3 * n
    blocks = []
    for row in range(n):
        dest = row_partner[row]
        blocks += [(pos + 3 * row, pos + 3 * dest, POLAR), (rot + 4 * row, rot + 4 * dest, QUAT),
                   (lin + 3 * row, lin + 3 * dest, POLAR), (ang + 3 * row, ang + 3 * dest, AXIAL)]
    ref_pos = obs_dim(character) - 1
    ref_rot = ref_pos + 3 * k
    for step in range(k):
        blocks += [(ref_pos + 3 * step, ref_pos + 3 * step, POLAR), (ref_rot + 4 * step, ref_rot + 4 * step, QUAT)]
    size, pose_width = obs_dim(character) + REFERENCE_OBS_WIDTH * k, pose_obs_width(character)
    for step in range(int(pose_steps)):  # each pose: its height stays, link positions swap sides
        start = size + pose_width * step
        blocks += [(start + 1 + 3 * row, start + 1 + 3 * row_partner[row], POLAR) for row in range(n)]
    return SignedPermutation.from_blocks(size + pose_width * int(pose_steps), blocks)


def mirror_motion(motion, character=None):
    """The clip (a `ReferenceMotion`) reflected in the world's x-z plane, left and right swapped, named
    `<name>_mirror` (or back to `<name>`), in the same body's pose space (`character`: the
    registered one `motion.character` names when not given). Joint rotations are local, so each
    is S R S of its partner's: a robot's hinge stored as a rotation about its axis comes out as
    the rotation about the partner's axis by sign x the angle (the partners' rest frames reflect
    into each other, `symmetry.derive_hinge_mirror_signs`). Timing and looping are the original's; extras
    (keypoints, camera tracks of a video reconstruction) are dropped, since they describe
    the original images."""
    if character is None:
        from actors.character.characters import character_named

        character = character_named(motion.character)
    return type(motion)(
        name=mirrored_name(motion.name, motion.character),
        frame_times=motion.frame_times.copy(),
        root_pos=motion.root_pos * POLAR,
        root_rot=motion.root_rot * QUAT,
        joint_rot=motion.joint_rot[:, character.joint_mirror] * QUAT,
        loop=motion.loop,
        character=motion.character,
    )
