"""Settings of `sfv complete`."""
from __future__ import annotations

from dataclasses import dataclass, field

from learner.errors import SfvError

MAX_SIDE = 4096


@dataclass(frozen=True)
class CompletionConfig:
    seconds: float = field(default=3.0, metadata={"help": "seconds of motion to predict (the simulation stops earlier if the character falls)"})
    height: int = field(default=480, metadata={"help": "video height in pixels (even); the image panel is scaled to it"})
    sim_width: int = field(default=640, metadata={"help": "width of the simulation panel in pixels (even)"})
    max_image_width: int = field(default=960, metadata={"help": "widest the image panel may get (wide images are letterboxed)"})
    fit_iterations: int = field(default=300, metadata={"help": "Adam steps fitting the humanoid's joint rotations to the image's 3D landmarks"})
    fit_lr: float = field(default=0.05, metadata={"help": "Adam step size of that fit (radians)"})
    camera_distance: float = field(default=3.5, metadata={"help": "metres from the simulation camera to the character's hips"})
    camera_elevation: float = field(default=-10.0, metadata={"help": "degrees; negative looks down on the character"})
    min_visibility: float = field(default=0.5, metadata={"help": "landmarks less visible than this are drawn hollow on the image"})

    def validate(self) -> None:
        if not self.seconds > 0 or self.seconds > 600:
            raise SfvError(f"complete: --seconds must be in (0, 600], got {self.seconds}")
        if self.height % 2 or self.sim_width % 2 or not (16 <= self.height <= MAX_SIDE and 16 <= self.sim_width <= MAX_SIDE):
            raise SfvError(f"complete: --height/--width must be even numbers in [16, {MAX_SIDE}], got {self.sim_width}x{self.height}")
        if self.fit_iterations < 1 or not self.fit_lr > 0:
            raise SfvError("complete: the fit needs at least one iteration and a positive step size")
