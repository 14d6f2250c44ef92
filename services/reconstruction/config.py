"""Settings of motion reconstruction (SFV section 6)."""
from __future__ import annotations

from dataclasses import dataclass, field

from services.reconstruction.losses import BALANCE_MODES, SMOOTHNESS_MODES


@dataclass(frozen=True)
class ReconstructionConfig:
    # --- the reconstruction loss l_rec = w2D l2D + w3D l3D + wsm lsm (SFV's weights)
    w_2d: float = field(default=10.0, metadata={"help": "weight of the 2D reprojection loss (paper: 10)"})
    w_3d: float = field(default=100.0, metadata={"help": "weight of the 3D-prediction rotation loss (paper: 100)"})
    w_smooth: float = field(default=25.0, metadata={"help": "weight of the joint-position smoothness loss (paper: 25)"})
    smoothness: str = field(default="stance", metadata={"choices": SMOOTHNESS_MODES, "help":
        "what the smoothness loss charges (services/reconstruction/losses.py smoothness): stance, as body but the ankle "
        "of a foot down at both frames is charged for its own displacement, not its displacement about the hips (a "
        "4 m/s side-view run: stance ankles 2.8 -> 0.9 m/s, reprojection 9.7 -> 8.5 px; docs/video.md cause 18); "
        "body, the joints' "
        "displacement about the hips as SFV's l_sm and the hips' travel only where it changes; displacement, "
        "SFV's l_sm as printed, which charges travel itself (a 3 m side-view run came out 1.2 m short, 28 px "
        "of reprojection against 10 with body; the eight Pose2Sim cameras: PA-MPJPE 85.8 against 85.7 mm, "
        "acceleration error 50.6 against 48.6); acceleration, each joint's change of displacement"})
    image_unit: float = field(default=1e-3, metadata={
        "help": "unit of the 2D residuals in l2D and delta_t, as a fraction of the image height (per mille): the "
                "paper's pixel units made independent of the video's resolution"})
    length_unit_m: float = field(default=0.01, metadata={
        "help": "metres per length unit of the joint positions in lsm and the ground penalty (centimetres)"})
    delta_scale: float = field(default=20.0, metadata={
        "help": "image units per unit of delta_t in w_t = exp(-delta_t): the confidence-weighted mean "
                "reprojection error of the 3D prediction (per mille of the image height) is divided by this"})
    w_ground: float = field(default=100.0, metadata={
        "help": "weight of the squared depth (length units) of foot corners below the ground plane"})
    w_contact: float = field(default=100.0, metadata={
        "help": "weight of the squared height (length units) of a contact foot's lowest point above or below the "
                "ground, where the foot-contact estimator says the foot is down (0: no contact terms)"})
    w_slide: float = field(default=100.0, metadata={
        "help": "weight of the horizontal step (length units, Charbonnier) of a contact foot between adjacent frames "
                "in which it is down at both (cam01: 100 halves the robust term's 2D cost of a squared one, 11.3 vs "
                "12.2 px, at the same skating, 0.49 m/s)"})
    w_balance: float = field(default=50.0, metadata={
        "help": "weight of the balance term (`balance`): the horizontal distance (length units, Charbonnier) of the "
                "zero-moment point or the whole-body centre of mass beyond balance_margin_m from the support of the "
                "contact feet, in frames where at least one is down; needs the contact terms (w_contact > 0); 0: off. "
                "Measured with the static point: "
                "Pose2Sim, 4 cameras: 50 brings the centre of mass from 13-17 to 8-11 cm of the support (mean over "
                "contact frames) for +0.7 to +1.5 px of reprojection error and -1.1 to +0.9 mm PA-MPJPE; 100 gets "
                "5-8 cm for +1.4 to +3.2 px (bench/results/reconstruction_balance.json)"})
    w_flat: float = field(default=10.0, metadata={
        "help": "weight of the squared heel-to-toe height (length units) of a foot the contact estimator says is down: "
                "it stands on its sole. 10: stance tilt 6-10 -> 1.2-2.8 cm, PA-MPJPE -0.5 to +1.6 mm; balancing cam01's "
                "controller then completes without help (docs/video.md)"})
    balance: str = field(default="dynamic", metadata={"choices": BALANCE_MODES, "help":
        "the point the balance term keeps over the support (services/reconstruction/losses.py): dynamic, the "
        "zero-moment point, where the ground's reaction must act for the centre of mass to accelerate as the motion "
        "says (the eight Pose2Sim cameras: 43 -> 5 cm from the support, median; PA-MPJPE +1.0 mm, reprojection +0.4 "
        "px; balancing cam02's controller then completes without help; docs/video.md cause 19); static, the centre "
        "of mass itself, which leaves its shaking free (DeepMimic's walk accelerates it 0.6 m/s^2 sideways, the "
        "videos' references 2.8-6.9); whole_body, the zero-moment point of all 15 links' masses, which also "
        "charges the spin about the centre of mass (limbs swung or shaking in depth; the Pose2Sim cameras: its 90th "
        "percentile 23.7 -> 14.9 cm from the support at the same PA-MPJPE, the controllers' help unchanged, so not the "
        "default; docs/video.md cause 20)"})
    balance_flight: bool = field(default=True, metadata={
        "help": "with the dynamic balance term, also charge a frame with no foot down for its centre of mass's "
                "departure from a free fall (services/reconstruction/losses.py flight_deviation; a 4 m/s run's flight "
                "92 -> 24 cm, its controller's help 34 -> 24 % of body weight)"})
    balance_window_s: float = field(default=0.1, metadata={
        "help": "seconds either side of a frame over which the dynamic balance term takes the centre of mass's acceleration"})
    balance_margin_m: float = field(default=0.05, metadata={
        "help": "distance (m) from the support within which the centre of mass costs nothing in the balance term"})
    # --- optimiser
    iterations: int = field(default=400, metadata={"help": "Adam steps of the reconstruction"})
    lr_rotation: float = field(default=0.01, metadata={"help": "Adam step size of the rotation parameters (radians)"})
    lr_position: float = field(default=0.005, metadata={"help": "Adam step size of the root position (metres)"})
    final_lr_fraction: float = field(default=0.1, metadata={"help": "step size at the last iteration, as a fraction of the first (exponential decay)"})
    ik_iterations: int = field(default=200, metadata={"help": "Adam steps of the per-frame fit of the 3D prediction"})
    ik_lr: float = field(default=0.05, metadata={"help": "Adam step size of the per-frame fit (radians)"})
    # --- camera
    focal_length_px: float = field(default=0.0, metadata={
        "help": "camera focal length in pixels; 0 means max(image width, height), about a 53 degree field of view "
                "on the long side"})
    up_from_body: bool = field(default=True, metadata={
        "help": "estimate the ground's up direction from the mean ankle-to-shoulder axis of the 3D prediction when "
                "the person is upright most of the clip; otherwise assume a level camera (image up = world up)"})
    up_from_balance: bool = field(default=True, metadata={
        "help": "with contacts, turn the body's up to the mean direction from the feet down to the centre of mass "
                "(a person on the ground stands over their support): 5.9 against 12.7 degrees from the calibrated "
                "vertical, mean over the eight Pose2Sim cameras (services/reconstruction/camera.py balance_up)"})
    level_travel: bool = field(default=True, metadata={
        "help": "when the root's path spans at least 1 m, make the up perpendicular to its main direction (people "
                "walk and run on level ground; the body's lean tilts the ground along the path: a side-view run "
                "across 3 m rose 0.44 m) (services/reconstruction/camera.py level_along)"})
    min_upright_consistency: float = field(default=0.8, metadata={
        "help": "length of the mean unit body axis above which the person counts as upright for up_from_body"})
    # --- left/right label flips
    fix_label_flips: bool = field(default=True, metadata={
        "help": "find frames where the pose estimator swapped the person's left and right (a mirrored reading of "
                "the body) by temporal coherence and undo the swap before reconstruction"})
    flip_overrule_cost: float = field(default=0.02, metadata={
        "help": "price of overruling the estimator's left/right reading in one frame, in the units of a jump "
                "(fraction of the person's height); small, so that a wrong reading held for many frames is still "
                "undone when its start and end are visible jumps"})
    dtype: str = field(default="float64", metadata={"help": "torch dtype of the optimisation (float32 or float64)"})

    def __post_init__(self):
        if self.smoothness not in SMOOTHNESS_MODES:
            raise ValueError(f"smoothness must be one of {', '.join(SMOOTHNESS_MODES)}, got {self.smoothness!r}")
        if self.balance not in BALANCE_MODES:
            raise ValueError(f"balance must be one of {', '.join(BALANCE_MODES)}, got {self.balance!r}")
        if not self.balance_window_s > 0:
            raise ValueError(f"balance_window_s must be positive, got {self.balance_window_s}")
