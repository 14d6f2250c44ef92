"""`sfv pipeline`'s training settings: `sfv train`'s flags (`services/training/flags.py`, one
source of defaults and help text), less those the pipeline sets itself."""
from __future__ import annotations

# Training settings the pipeline sets itself: the motion is the reconstruction's; `--scene` is the
# moving-camera path's boxes (fitted), not a fixed scene.
PIPELINE_SETS = frozenset({"motion", "env.scene"})

# The static pipeline's own defaults, where `sfv train`'s are a quick first run (200 k samples) on
# any clip: a user's video should end in a controller that completes the clip from its first frame.
# Pose2Sim, one worker, 2 M samples (31-38 min on shared cores): with ASI's uniform phases alone the
# first frames got a ninth of the last frames' samples, and cam01's controller fell at 1.5 s of the
# 1.67 s clip from the first frame (in-training eval .79, 1 of 8 falling); with half the episodes
# started at the first frame (`first_frame_share`, FirstFrameStarts) cam01 and cam03 both complete
# it upright (NR .767 and .849). sfv train keeps 0 until the clips that do not loop among the
# DeepMimic ones (kick, punch, the getups) have been retrained with it.
STATIC_DEFAULTS = {"samples": 2_000_000, "first_frame_share": 0.5}
PIPELINE_DEFAULT_TEXT = {
    "samples": f"{STATIC_DEFAULTS['samples']} with a static camera, sfv train's per window with --camera moving",
    "first_frame_share": f"{STATIC_DEFAULTS['first_frame_share']} with a static camera, 0 with --camera moving",
}


def train_config(args, motion: str, out: str, defaults: dict | None = None):
    """The training's TrainConfig: `sfv train`'s defaults, then the pipeline's `defaults`
    ({config path: value}), then --config, then the flags given."""
    from learner.errors import SfvError
    from services.training.flags import chosen_presets, given_settings, read_config_file, resolve

    given, flags = {}, {}
    if args.config is not None:
        given = read_config_file(args.config)
        flags = {path: f"{args.config}: {path}" for path in given}
        for path in PIPELINE_SETS.union({"out"}).intersection(given):
            raise SfvError(f"{args.config}: {path} is set by sfv pipeline, not by its config file")
    from_flags, flag_names = given_settings(args)
    given.update(from_flags)
    flags.update(flag_names)
    for path, value in (defaults or {}).items():
        if path not in given:
            given[path], flags[path] = value, f"sfv pipeline's default {path}"
    config = resolve(given, flags, None, chosen_presets(args))
    config.motion, config.out = motion, out
    config.validate()
    return config
