"""The terms of SFV's reconstruction loss (section 6), per frame, in torch.

    l_rec = w2D l2D + w3D l3D + wsm lsm
    l2D = sum_t sum_j c_tj |x_tj - Pi(F_j(q_t))|_1
    l3D = sum_t w_t sum_k dist(q_hat_tk, q_tk),   w_t = exp(-delta_t)
    lsm = sum_t sum_j |F_j(q_t) - F_j(q_t+1)|^2

and, where the foot-contact estimator says a foot is down (SFV section 6 asks the motion to be
one a physics character can follow; movingcam's contact reward and PhysCap's foot constraints
are the same idea), two contact terms and the no-penetration term:

    lcontact = sum_t sum_f c_tf (z_tf - g)^2          z_tf the foot's lowest point, g the ground
    lslide   = sum_t sum_f c_tf c_t+1,f rho(|p_t+1,f - p_tf|_xy)   p the foot's centre, rho Charbonnier
    lground  = sum_t sum_corners relu(g - z)^2

and, in the frames where at least one foot is down, a static-balance term (PhysCap's and
SimPoE's physical plausibility, reduced to its static part): the horizontal distance d_t of
the whole-body centre of mass from the support, beyond a margin m, pays a Charbonnier rho:

    lbalance = sum_t [any c_t] rho(relu(d_t - m))

the support being a contact foot's heel-toe segment, or with both feet down the convex hull of
their heels and toes (horizontal: the ground is z = const). Its dynamic form (`dynamic_balance`,
`ReconstructionConfig.balance`) charges the zero-moment point instead of the centre of mass: where
the ground's reaction must act for the centre of mass to accelerate as the motion says,

    zmp_t = c_t,xy - (c_t,z - g0) / (g + a_t,z) a_t,xy,   a_t the centre of mass's acceleration,

which is the static term's point when the body does not accelerate. SFV's loss and the contact terms
leave the centre of mass 13-17 cm (mean over contact frames) from the support on the Pose2Sim
cameras, where the markers' is 3 cm; w_balance 50 brings it to 8-11 cm (+0.7-1.5 px, PA-MPJPE
-1.1 to +0.9 mm), but pure PD tracking from the first frame gains little (29-32 -> 26-33 of 49
control steps): the estimator leaves most of the one-leg stance without a foot down (cam01
frames 30-44), where the term does not act (bench/results/reconstruction_balance.json).

2D residuals are in image units (per mille of the image height by default,
`ReconstructionConfig.image_unit`), joint positions in a length unit (centimetres,
`ReconstructionConfig.length_unit_m`), rotations in radians. The functions return one value per frame
(or frame pair); the caller averages over frames, so the balance between the terms does not
depend on the clip's length.
"""
from __future__ import annotations

import torch

from services.reconstruction import quaternion_torch as qt


def reprojection_l1(projected: torch.Tensor, observed: torch.Tensor, weight: torch.Tensor, px_to_unit: float) -> torch.Tensor:
    """(T,) sum over points of weight * L1 distance, in image units.
    projected, observed: (T, P, 2) pixels; weight: (T, P) confidence times point weight;
    px_to_unit: image units per pixel."""
    return (weight * (projected - observed).abs().sum(-1)).sum(-1) * px_to_unit


def reprojection_error(projected, observed, weight, px_to_unit: float):
    """(T,) weighted mean Euclidean reprojection error in image units (delta_t before scaling);
    zero on frames whose weights are all zero."""
    distance = (projected - observed).norm(dim=-1)
    total = weight.sum(-1)
    return (weight * distance).sum(-1) / total.clamp_min(1e-9) * px_to_unit


def rotation_distance(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Angle (radians) of the rotation taking a to b, for unit quaternions (..., 4)."""
    return qt.quat_angle(qt.quat_mul(qt.quat_conj(a), b))


def prediction_consistency(rotations: torch.Tensor, predicted: torch.Tensor, frame_weight: torch.Tensor) -> torch.Tensor:
    """(T,) w_t * sum_k dist(q_hat_tk, q_tk) over the rotations (T, K, 4) (root and joints)."""
    return frame_weight * rotation_distance(predicted, rotations).sum(-1)


SMOOTHNESS_MODES = ("body", "stance", "displacement", "acceleration")


def smoothness(points: torch.Tensor, unit_m: float, mode: str = "displacement", centre: torch.Tensor | None = None,
               held: torch.Tensor | None = None) -> torch.Tensor:
    """Per frame pair (or triple), the smoothness loss over joints (T, J, 3), in length units^2:
    - "displacement": the squared displacement of every joint between adjacent frames, SFV's l_sm
      as printed. It charges travel itself: a subject who runs across the view is pulled towards
      standing still, and a 3 m run (measured below) came out 1.2 m short.
    - "acceleration": the squared change of each joint's displacement.
    - "body": the joints' displacement about `centre` (T, 3; the hips' midpoint) as SFV's, plus J
      times the squared change of the centre's displacement: the body's own motion is smoothed as
      the paper does, the travel only where it changes.
    - "stance": "body", except that a joint `held` (T - 1, J; 1 where a foot down at both frames
      holds it: its ankle) is charged for its own displacement, not its displacement about the
      hips. A planted foot moves about the hips at the body's speed, and "body" pulled it along
      with them: on a side-view run at 4 m/s the reference's stance ankles slid at 2.8 m/s, 0.9
      with the ankle charged where it stands (docs/video.md, cause 18).
    (T - 1,) for "displacement", (T - 2,) for the others."""
    if mode in ("body", "stance"):
        step = torch.diff(points - centre[:, None], dim=0) / unit_m
        if mode == "stance" and held is not None:  # a held joint's own displacement: a planted ankle stays put
            held = held[..., None]
            step = held * torch.diff(points, dim=0) / unit_m + (1.0 - held) * step
        charged = (step * step).sum(-1)  # (T - 1, J)
        travel = torch.diff(centre, n=2, dim=0) / unit_m
        return charged.sum(-1)[1:] + points.shape[1] * (travel * travel).sum(-1)
    if mode not in SMOOTHNESS_MODES:
        raise ValueError(f"smoothness mode must be one of {SMOOTHNESS_MODES}, got {mode!r}")
    step = torch.diff(points, n=1 if mode == "displacement" else 2, dim=0) / unit_m
    return (step * step).sum((-1, -2))


def ground_penetration(foot_corners: torch.Tensor, unit_m: float, ground=0.0) -> torch.Tensor:
    """(T,) sum of squared depths (length units) of foot corners (T, ..., 3) below z = ground."""
    below = torch.relu(ground - foot_corners[..., 2]) / unit_m
    return (below * below).flatten(1).sum(-1)


def contact_height(foot_corners: torch.Tensor, contacts: torch.Tensor, unit_m: float, ground=0.0) -> torch.Tensor:
    """(T,) sum over the feet in contact (contacts (T, F) 0/1) of the squared height (length
    units) of the foot's lowest corner above the ground (or below it); foot_corners (T, F, C, 3)."""
    height = (foot_corners[..., 2].min(dim=-1).values - ground) / unit_m
    return (contacts * height * height).sum(-1)


def stance_tilt(heels: torch.Tensor, toes: torch.Tensor, contacts: torch.Tensor, unit_m: float) -> torch.Tensor:
    """(T,) sum over the feet in contact of the squared height difference (length units) between
    the sole's heel and toe points (T, F, 3): a foot that bears weight stands on its sole, not
    on the edge of its toes or heel."""
    rise = (toes[..., 2] - heels[..., 2]) / unit_m
    return (contacts * rise * rise).sum(-1)


def contact_sliding(foot_corners: torch.Tensor, contacts: torch.Tensor, unit_m: float, smooth: float = 0.1) -> torch.Tensor:
    """(T-1,) sum over the feet in contact at both ends of a frame pair of the horizontal step
    (length units) of the foot's centre (the mean of its corners (T, F, C, 3)), as the
    Charbonnier sqrt(step^2 + smooth^2) - smooth: near zero it pins the foot as an L1 term does,
    and a foot the estimator calls down while it swings pays linearly, not quadratically."""
    centre = foot_corners[..., :2].mean(dim=-2) / unit_m
    step = centre[1:] - centre[:-1]
    held = contacts[1:] * contacts[:-1]
    return (held * ((step * step).sum(-1) + smooth * smooth).sqrt() - held * smooth).sum(-1)


def point_segment_distance(point: torch.Tensor, start: torch.Tensor, end: torch.Tensor) -> torch.Tensor:
    """(...,) distance from points (..., D) to the segments start-end (..., D); a segment of
    zero length is its point."""
    along = end - start
    length2 = (along * along).sum(-1)
    t = ((point - start) * along).sum(-1) / length2.clamp_min(1e-12)
    nearest = start + t.clamp(0.0, 1.0).unsqueeze(-1) * along
    return ((point - nearest) ** 2).sum(-1).clamp_min(1e-18).sqrt()


def _inside_triangle(point: torch.Tensor, a: torch.Tensor, b: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
    """(...,) bool: 2D points (..., 2) inside (or on) the triangles a, b, c (..., 2), either winding."""
    def cross(o, p, q):
        return (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (p[..., 1] - o[..., 1]) * (q[..., 0] - o[..., 0])

    d1, d2, d3 = cross(a, b, point), cross(b, c, point), cross(c, a, point)
    return ((d1 >= 0) & (d2 >= 0) & (d3 >= 0)) | ((d1 <= 0) & (d2 <= 0) & (d3 <= 0))


def support_distance(com_xy: torch.Tensor, heels_xy: torch.Tensor, toes_xy: torch.Tensor, contacts: torch.Tensor) -> torch.Tensor:
    """(T,) horizontal distance of the centre of mass (T, 2) from the support of the feet down
    (contacts (T, F=2) 0/1, heels and toes (T, 2, 2), feet in the same order): one foot down,
    its heel-toe segment; both, the convex hull of the two heels and toes (0 inside it, else
    the nearest of the six segments between those points, the hull's edges among them). 0
    where no foot is down (the caller masks those frames anyway)."""
    feet = point_segment_distance(com_xy.unsqueeze(-2), heels_xy, toes_xy)  # (T, 2)
    down = contacts > 0.5
    big = torch.full_like(feet, torch.finfo(feet.dtype).max)
    one_foot = torch.where(down, feet, big).min(dim=-1).values
    corners = (heels_xy[:, 0], toes_xy[:, 0], heels_xy[:, 1], toes_xy[:, 1])
    pairs = [(i, j) for i in range(4) for j in range(i + 1, 4)]
    edges = torch.stack([point_segment_distance(com_xy, corners[i], corners[j]) for i, j in pairs], dim=-1)
    triples = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
    inside = torch.stack([_inside_triangle(com_xy, *(corners[k] for k in t)) for t in triples], dim=-1).any(dim=-1)
    two_feet = torch.where(inside, torch.zeros_like(one_foot), edges.min(dim=-1).values)
    distance = torch.where(down.all(dim=-1), two_feet, one_foot)
    return torch.where(down.any(dim=-1), distance, torch.zeros_like(distance))


BALANCE_MODES = ("static", "dynamic", "whole_body")
GRAVITY = 9.81
# The zero-moment point's lever h / (g + a_z) is bounded as if the body fell at no more than
# 0.7 g: a frame the contacts call down that the motion says falls freely would divide by ~0.
MIN_SUPPORT_ACCEL = 0.3 * GRAVITY


def beyond_margin(distance: torch.Tensor, unit_m: float, margin_m: float, smooth: float = 1.0) -> torch.Tensor:
    """rho(relu(d - margin)) in length units, rho(e) = sqrt(e^2 + smooth^2) - smooth: quadratic near 0,
    linear far out, so a foot wrongly called down pulls the body with a bounded force."""
    excess = torch.relu(distance - margin_m) / unit_m
    return (excess * excess + smooth * smooth).sqrt() - smooth


def centre_acceleration(com: torch.Tensor, fps: float, half_window: int) -> torch.Tensor:
    """(T - 2k, ..., 3) central second difference of the centre of mass (T, 3) or of points (T, N, 3),
    metres, over k = `half_window` frames either side: m/s^2 at frames k .. T - k - 1."""
    k = half_window
    return (com[2 * k:] - 2.0 * com[k:-k] + com[:-2 * k]) * (fps / k) ** 2


def zero_moment_point(com: torch.Tensor, acceleration: torch.Tensor, ground) -> torch.Tensor:
    """(T, 2) the point on the ground (height `ground`) where the reaction must act for the centre of
    mass (T, 3) to accelerate as `acceleration` (T, 3) says, the body's spin about its centre of mass
    left out (the linear inverted pendulum's zero-moment point, with the height free)."""
    height = com[:, 2] - ground
    lever = height / (GRAVITY + acceleration[:, 2]).clamp(min=MIN_SUPPORT_ACCEL)
    return com[:, :2] - lever.unsqueeze(-1) * acceleration[:, :2]


def whole_body_zero_moment_point(centres: torch.Tensor, masses: torch.Tensor, accelerations: torch.Tensor,
                                 ground) -> torch.Tensor:
    """(T, 2) the zero-moment point of the links as point masses: their centres of mass (T, N, 3), shares
    of the body's mass (N,) and accelerations (T, N, 3). The point p on the ground where sum_i m_i (r_i - p)
    x (a_i - g) has no horizontal part, p = sum m_i ((g + a_iz) r_i,xy - a_i,xy h_i) / sum m_i (g + a_iz), h_i
    the link's height: `zero_moment_point` with the body's spin about its centre of mass put back (an arm
    swung, a leg thrown out, the trunk pitched), each link's own inertia about its centre left out. With
    one link it is `zero_moment_point`."""
    weights = masses.to(centres.dtype).unsqueeze(-1)
    vertical = accelerations[..., 2:3] + GRAVITY
    height = centres[..., 2:3] - ground
    moment = (weights * (vertical * centres[..., :2] - accelerations[..., :2] * height)).sum(-2)
    return moment / (weights * vertical).sum(-2).clamp(min=MIN_SUPPORT_ACCEL)


def flight_deviation(com: torch.Tensor, acceleration: torch.Tensor, ground) -> torch.Tensor:
    """(T,) metres: how far from falling freely the centre of mass (T, 3) moves, as the lever the
    force it needs would have, |a - g| (c_z - g0) / g (for a sideways push the same length as
    `zero_moment_point`'s offset). A body with no foot down has nothing to push on."""
    gravity = torch.tensor([0.0, 0.0, -GRAVITY], dtype=com.dtype)
    return (acceleration - gravity).norm(dim=-1) * (com[:, 2] - ground) / GRAVITY


def dynamic_balance(com: torch.Tensor, heels: torch.Tensor, toes: torch.Tensor, contacts: torch.Tensor, unit_m: float,
                    margin_m: float, fps: float, half_window: int, ground=0.0, smooth: float = 1.0,
                    flight: bool = False, links: tuple[torch.Tensor, torch.Tensor] | None = None) -> torch.Tensor:
    """(T,) rho(relu(d - margin)) as `static_balance`, d the zero-moment point's horizontal distance from
    the support (`zero_moment_point`, the acceleration over `half_window` frames either side); the first
    and last `half_window` frames, which have no central difference, keep the centre of mass itself.
    With `flight`, a frame with no foot down is charged `flight_deviation` beyond the margin (else nothing).
    With `links` (the links' centres of mass (T, N, 3) and mass shares (N,)), the zero-moment point is the
    whole body's (`whole_body_zero_moment_point`), the spin about the centre of mass included.
    Measured on the references (`bench/scripts/dynamic_balance.py`): DeepMimic's walk keeps its
    zero-moment point 3 cm from the support (median over contact frames, 0.1 s either side), a
    video's reconstruction 26-63 cm, its centre of mass accelerating sideways 5-12 times as hard."""
    point = com[:, :2]
    k = half_window
    down = (contacts > 0.5).any(dim=-1)
    airborne = torch.zeros_like(com[:, 0])
    if len(com) > 2 * k:
        acceleration = centre_acceleration(com, fps, k)
        if links is None:
            zmp = zero_moment_point(com[k:-k], acceleration, ground)
        else:
            centres, masses = links
            zmp = whole_body_zero_moment_point(centres[k:-k], masses, centre_acceleration(centres, fps, k), ground)
        point = torch.cat((point[:k], zmp, point[-k:]))
        if flight:
            airborne = torch.cat((airborne[:k], flight_deviation(com[k:-k], acceleration, ground), airborne[-k:]))
    distance = support_distance(point, heels[..., :2], toes[..., :2], contacts)
    distance = torch.where(down, distance, airborne)
    return beyond_margin(distance, unit_m, margin_m, smooth)


def static_balance(com: torch.Tensor, heels: torch.Tensor, toes: torch.Tensor, contacts: torch.Tensor, unit_m: float,
                   margin_m: float, smooth: float = 1.0) -> torch.Tensor:
    """(T,) rho(relu(d - margin)) in length units, d the centre of mass's (T, 3) horizontal
    distance from the support (`support_distance`; heels, toes (T, 2, 3) the feet's sole
    points), rho(e) = sqrt(e^2 + smooth^2) - smooth (near 0 quadratic, linear far out, so a
    foot the estimator wrongly calls down pulls the body with a bounded force); 0 in frames
    with no foot down."""
    distance = support_distance(com[..., :2], heels[..., :2], toes[..., :2], contacts)
    down = (contacts > 0.5).any(dim=-1).to(com.dtype)
    return down * beyond_margin(distance, unit_m, margin_m, smooth)
