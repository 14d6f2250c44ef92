"""The imitation reward: DeepMimic's (the code behind SFV's numbers), with SFV's paper form one flag away.

r = w_p exp(-k_p E_pose) + w_v exp(-k_v E_vel) + w_e exp(-k_e E_ee) + w_r exp(-k_r E_root) + w_c exp(-k_c E_com)

SFV §7.2 writes plain sums over the joints (E_pose = sum_j |q*_j (-) q_j|^2, ...), four terms
(.65/.1/.15/.1) and the centre of mass's position. The code that produced SFV's Table 1 is
DeepMimic's (`SceneImitate::CalcRewardImitate`), and it differs in ways that matter for
learning, so it is the default ("deepmimic"):
- E_pose and E_vel are *weighted means* over the joints: per-joint weights (DeepMimic's
  `DiffWeight`: root 1, chest and hips .5, neck, knees and shoulders .3, ankles and elbows .2,
  wrists 0) divided by their sum (`CalcJointWeights`). With 0.3 rad off at every joint the
  pose term is exp(-2 * .09) = 0.84, where the paper's sum over 13 rotations gives 0.10: the
  sum leaves almost no imitation signal in the advantage once a few joints are off.
- E_ee is the mean squared end-effector error with k_e = 40 (DeepMimic sums over the four
  with k_e = 10: the same number). End effectors are offsets from the root in the heading
  frame with their height above the ground.
- A root term (w .2, k 5): |root pos error|^2 + .1 root angle^2 + .01 |root vel error|^2
  + .001 |root angular-velocity error|^2. The reference's horizontal root is re-synchronised
  to the character's at every new cycle of a looped clip (`sync_char_root_pos`), so drift
  costs reward within a cycle but does not accumulate into a lost cause.
- The centre-of-mass term compares *velocities* (E_com = .1 |v*_com - v_com|^2, k 10), not
  world positions, which drift without bound over a 20 s episode.
Weights (.5/.05/.15/.2/.1) are DeepMimic's, which sum to 1.
- Rotations: for a ball joint the angle of q*^-1 q is 2 acos|<q*, q>|; for a hinge the angle
  difference. Angular velocities are MuJoCo's qvel[3:]: the root's and each ball joint's
  local angular velocity and each hinge's rate.

Every term's error is one matrix product: squared feature differences (B, D) times a (D, 5)
weight matrix (plus the squared quaternion angles (B, 9) times a (9, 5) one), so weighted
means, sums and the root term's mixture are all the same few whole-batch operations.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from actors.character.features import RewardFeatures, RewardShape

REWARD_FORMS = ("deepmimic", "sfv_paper")
TERM_NAMES = ("pose", "velocity", "end_effector", "root", "com")
NUM_TERMS = len(TERM_NAMES)


@dataclass(frozen=True)
class RewardConfig:
    form: str = field(default="deepmimic", metadata={"choices": REWARD_FORMS, "help": "deepmimic: weighted-mean joint errors, root term, centre-of-mass velocity (the code behind SFV's numbers); sfv_paper: the paper's plain sums and centre-of-mass position (weights/scales then as the paper's)"})
    pose_weight: float = field(default=0.5, metadata={"help": "w_p, weight of the joint-rotation term (DeepMimic .5; paper .65)"})
    velocity_weight: float = field(default=0.05, metadata={"help": "w_v, weight of the joint angular-velocity term (DeepMimic .05; paper .1)"})
    end_effector_weight: float = field(default=0.15, metadata={"help": "w_e, weight of the hands-and-feet position term"})
    root_weight: float = field(default=0.2, metadata={"help": "w_r, weight of the root position/rotation/velocity term (DeepMimic .2; the paper has none)"})
    com_weight: float = field(default=0.1, metadata={"help": "w_c, weight of the centre-of-mass term"})
    pose_scale: float = field(default=2.0, metadata={"help": "k_p in exp(-k_p * error)"})
    velocity_scale: float = field(default=0.1, metadata={"help": "k_v"})
    end_effector_scale: float = field(default=40.0, metadata={"help": "k_e (on the mean over the 4 end effectors in the deepmimic form, on their sum in the paper's)"})
    root_scale: float = field(default=5.0, metadata={"help": "k_r"})
    com_scale: float = field(default=10.0, metadata={"help": "k_c"})

    def __post_init__(self):
        if self.form not in REWARD_FORMS:
            raise ValueError(f"reward form must be one of {REWARD_FORMS}, got {self.form!r}")

    @classmethod
    def sfv_paper(cls) -> "RewardConfig":
        """SFV §7.2 as printed: sums over joints, four terms, centre-of-mass position."""
        return cls(form="sfv_paper", pose_weight=0.65, velocity_weight=0.1, end_effector_weight=0.15, root_weight=0.0, com_weight=0.1)

    @property
    def max_reward(self) -> float:
        return self.pose_weight + self.velocity_weight + self.end_effector_weight + self.root_weight + self.com_weight

    @property
    def weights(self) -> np.ndarray:
        return np.array([self.pose_weight, self.velocity_weight, self.end_effector_weight, self.root_weight, self.com_weight])

    @property
    def scales(self) -> np.ndarray:
        return np.array([self.pose_scale, self.velocity_scale, self.end_effector_scale, self.root_scale, self.com_scale])


def error_matrices(form: str, layout: RewardFeatures, body) -> tuple[np.ndarray, np.ndarray]:
    """(tail (D, 5), quaternion (quats, 5)) matrices that turn squared differences into the
    five terms' errors. `layout` is any RewardFeatures of the body (only its column ranges are
    read); `body` is the built character: its joints, their kinds and reward weights, and
    each joint's first qvel index `joint_dof_adr` (MuJoCo orders qvel by the body tree,
    hinges between ball joints, not by skeleton order)."""
    character = body.character
    # The weights are by link: the root's, and each joint's by the link it moves.
    root, spherical = character.link_names[0], character.joint_is_spherical
    names = [character.link_names[i] for i in character.joint_links]
    cols = layout.tail_columns
    tail = np.zeros((layout.tail.shape[1], NUM_TERMS))
    quat = np.zeros((layout.shape.quats, NUM_TERMS))
    weights = character.reward_joint_weights
    if form == "deepmimic":
        total = sum(weights.values())  # humanoid3d: the wrists' zeros add nothing
        w = {name: v / total for name, v in weights.items()}
    else:
        w = dict.fromkeys(weights, 1.0)
    ball = [n for n, s in zip(names, spherical) if s]
    hinge = [n for n, s in zip(names, spherical) if not s]
    # Pose: root (world) and ball joints by their quaternion angle, hinges by angle gap.
    quat[:, 0] = [w[root]] + [w[n] for n in ball]
    h0 = cols["hinges"][0]
    tail[h0:h0 + len(hinge), 0] = [w[n] for n in hinge]
    # Velocity: qvel[3:] = root angular velocity (3), then each joint's dofs at its address.
    a0 = cols["ang_vel"][0]
    tail[a0:a0 + 3, 1] = w[root]
    for name, ball_joint, adr in zip(names, spherical, np.asarray(body.joint_dof_adr)):
        first = a0 + int(adr) - 3
        tail[first:first + (3 if ball_joint else 1), 1] = w[name]
    e0, e1 = cols["end_effectors"]
    if form == "deepmimic":
        tail[e0:e1, 2] = 1.0 / layout.shape.end_effectors  # mean over the end effectors
        r0, r1 = cols["root_pos"]
        tail[r0:r1, 3] = 1.0
        quat[0, 3] = 0.1
        v0, v1 = cols["root_lin_vel"]
        tail[v0:v1, 3] = 0.01
        tail[a0:a0 + 3, 3] = 0.001
        c0, c1 = cols["com_vel"]
        tail[c0:c1, 4] = 0.1
    else:
        tail[e0:e1, 2] = 1.0
        c0, c1 = cols["com"]
        tail[c0:c1, 4] = 1.0
    return tail, quat


_DEFAULT_BODY: list = []


def _default_body():
    """humanoid3d, built once (its joint addresses are fixed by its skeleton)."""
    if not _DEFAULT_BODY:
        from actors.character.humanoid3d import HUMANOID3D

        _DEFAULT_BODY.append(HUMANOID3D.build())
    return _DEFAULT_BODY[0]


class ImitationReward:
    def __init__(self, config: RewardConfig = RewardConfig(), body=None):
        """`body`: the built character the env steps (humanoid3d when not given)."""
        self.config = config
        self._weights = config.weights
        self._scales = -config.scales
        body = _default_body() if body is None else body
        self._shape = RewardShape.of(body.character)
        layout = RewardFeatures.zeros(body.character.nv, 1, self._shape)
        self._tail_matrix, self._quat_matrix = error_matrices(config.form, layout, body)
        self._scratch: dict[tuple[int, int], tuple] = {}  # per (B, D): work buffers

    def batch(self, sim: RewardFeatures, ref: RewardFeatures, terms: np.ndarray) -> np.ndarray:
        """Rewards (B,) and their five terms in `terms` (B, 5)."""
        diff, angle, quat_err, rewards = self._buffers(sim.values.shape)
        np.subtract(sim.tail, ref.tail, out=diff)
        np.square(diff, out=diff)
        # The angle of q*^-1 q is 2 acos|<q*, q>|.
        np.vecdot(sim.quats, ref.quats, out=angle)
        np.abs(angle, out=angle)
        np.minimum(angle, 1.0, out=angle)
        np.arccos(angle, out=angle)
        angle *= 2.0
        np.square(angle, out=angle)
        np.matmul(diff, self._tail_matrix, out=terms)
        np.matmul(angle, self._quat_matrix, out=quat_err)
        terms += quat_err
        np.multiply(terms, self._scales, out=terms)
        np.exp(terms, out=terms)
        return np.matmul(terms, self._weights, out=rewards)

    def _buffers(self, shape: tuple[int, int]) -> tuple:
        if shape not in self._scratch:
            b, width = shape
            start = self._shape.hinge_start
            if width - start != self._tail_matrix.shape[0]:
                raise ValueError(f"reward features have {width} columns, the reward expects {self._tail_matrix.shape[0] + start}")
            self._scratch[shape] = (np.zeros((b, width - start)), np.zeros((b, self._shape.quats)),
                                    np.zeros((b, NUM_TERMS)), np.zeros(b))
        return self._scratch[shape]

    def __call__(self, sim: RewardFeatures, ref: RewardFeatures, terms: np.ndarray | None = None) -> float:
        """Reward of a batch of one; `terms` (5,) receives the five terms if given."""
        t = np.zeros((1, NUM_TERMS)) if terms is None else terms.reshape(1, NUM_TERMS)
        return float(self.batch(sim, ref, t)[0])
