"""`sfv pipeline`'s training settings: `sfv train`'s flags (`services/training/flags.py`, one
source of defaults and help text), less those the pipeline sets itself."""
from __future__ import annotations

from services.scene_fit.budget import WINDOW_SAMPLES
from services.specs import run_spec

# Training settings the pipeline sets itself: the motion is the reconstruction's; `--scene` is the
# moving-camera path's boxes (fitted), not a fixed scene.
PIPELINE_SETS = frozenset({"motion", "env.scene"})

# The static pipeline's own defaults: its registered run spec (services/specs/catalog.py says why).
STATIC_DEFAULTS = dict(run_spec("pipeline-static", "pipeline").settings)
PIPELINE_DEFAULT_TEXT = {
    "samples": f"{STATIC_DEFAULTS['samples']} with a static camera, {WINDOW_SAMPLES} per window with --camera moving",
    "first_frame_share": f"{STATIC_DEFAULTS['first_frame_share']} with a static camera, 0 with --camera moving",
    "env.residual_force": f"{STATIC_DEFAULTS['env.residual_force']} with a static camera, 0 with --camera moving",
}


def train_config(args, motion: str, out: str, defaults: dict | None = None, saved: dict | None = None):
    """The training's TrainConfig: `sfv train`'s defaults, then the pipeline's `defaults`
    ({config path: value}), then --config, then the flags given. `saved` (a run's config.json, for
    --resume): that run's settings replace the defaults, and the settings given follow `sfv train
    --resume`'s rules (one that cannot change is a one-line error)."""
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
    for path, value in (defaults or {}).items() if saved is None else ():
        if path not in given:
            given[path], flags[path] = value, f"sfv pipeline's default {path}"
    config = resolve(given, flags, saved, chosen_presets(args), resuming=saved is not None)
    config.motion, config.out = motion, out
    config.validate()
    return config
