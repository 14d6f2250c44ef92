"""Left/right mirroring of a character: states, actions, observations and whole clips.

NPMP (004 §3.2-3.3) distils one expert per clip; mirrored clips double the data for free
when the body is symmetric. Every map here reads the character's mirror maps (`link_mirror`,
`joint_mirror`) and joint kinds; humanoid3d is symmetric: in the Z-up frame of `skeleton.py` the
character faces +x with its right side at -y, every left link is its right partner's
reflection in the sagittal (x-z) plane (offsets, geoms, masses, gains), and the joint limits
reflect into each other (checked in `tests/actors/character/test_mirror.py`). The reflection S = diag(1, -1, 1)
acts on
- positions and linear velocities (polar vectors): (x, y, z) -> (x, -y, z);
- rotations R -> S R S, i.e. quaternions (w, x, y, z) -> (w, -x, y, -z), and rotation vectors
  or angular velocities (axial vectors) -> (-x, y, -z);
- hinges (axis (0, -1, 0), in the plane): the same angle;
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

MIRROR_SUFFIX = "_mirror"
POLAR = np.array([1.0, -1.0, 1.0])  # positions, linear velocities
AXIAL = np.array([-1.0, 1.0, -1.0])  # rotation vectors, angular velocities
QUAT = np.array([1.0, -1.0, 1.0, -1.0])  # (w, x, y, z) of S R S


def mirrored_name(name: str) -> str:
    """'walk' -> 'walk_mirror' and back (mirroring twice is the original)."""
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


def state_mirror(humanoid) -> tuple[SignedPermutation, SignedPermutation]:
    """(qpos map, qvel map) of MuJoCo's state vectors for this built character's joint addresses."""
    qadr, dadr = humanoid.joint_qpos_adr, humanoid.joint_dof_adr
    character = humanoid.character
    qpos_blocks = [(0, 0, POLAR), (3, 3, QUAT)]
    qvel_blocks = [(0, 0, POLAR), (3, 3, AXIAL)]
    for j, ball in enumerate(character.joint_is_spherical):
        p = character.joint_mirror[j]
        qpos_blocks.append((qadr[j], qadr[p], QUAT if ball else np.ones(1)))
        qvel_blocks.append((dadr[j], dadr[p], AXIAL if ball else np.ones(1)))
    return SignedPermutation.from_blocks(humanoid.nq, qpos_blocks), SignedPermutation.from_blocks(humanoid.nv, qvel_blocks)


def action_mirror(parameterisation: str = "exp_map", character=HUMANOID3D) -> SignedPermutation:
    """Map of the policy's action vector (`actions.py` layout: the spherical joints, then
    the revolute). exp_map: a rotation vector per ball joint (axial); axis_angle: (angle,
    axis), the angle kept and the axis axial. With exp_map (nu entries) this is also the map
    of the PD targets (MuJoCo ctrl / actuator lengths). The per-axis action scales and joint
    limits of partners mirror into each other, so scaling and clipping commute with it."""
    width, signs = (4, np.concatenate(([1.0], AXIAL))) if parameterisation == "axis_angle" else (3, AXIAL)
    balls = np.flatnonzero(character.joint_is_spherical).tolist()
    hinges = np.flatnonzero(~character.joint_is_spherical).tolist()
    partner = character.joint_mirror
    blocks = [(width * s, width * balls.index(partner[j]), signs) for s, j in enumerate(balls)]
    base = width * len(balls)
    blocks += [(base + r, base + hinges.index(partner[j]), np.ones(1)) for r, j in enumerate(hinges)]
    return SignedPermutation.from_blocks(base + len(hinges), blocks)


def observation_mirror(humanoid, reference_steps: int, pose_steps: int = 0) -> SignedPermutation:
    """Map of `FeatureExtractor.observations` (height, link positions, rotations, linear
    and angular velocities in the heading frame, K reference roots, phase), followed by
    `pose_steps` reference poses (`actors/envs/reference_obs.py`: height, link positions). Links
    there are in MuJoCo body order (bodies 1..n), not skeleton order."""
    character = humanoid.character
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


def mirror_motion(motion, character=HUMANOID3D):
    """The clip (a `ReferenceMotion`) reflected in the world's x-z plane, left and right swapped, named
    `<name>_mirror` (or back to `<name>`). Timing and looping are the original's; extras
    (keypoints, camera tracks of a video reconstruction) are dropped, since they describe
    the original images."""
    return type(motion)(
        name=mirrored_name(motion.name),
        frame_times=motion.frame_times.copy(),
        root_pos=motion.root_pos * POLAR,
        root_rot=motion.root_rot * QUAT,
        joint_rot=motion.joint_rot[:, character.joint_mirror] * QUAT,
        loop=motion.loop,
    )
