"""`sfv train`: PPO imitation of one motion with rollout workers and an ASI server.

The settings are the config dataclasses' fields (`services/training/flags.py` generates a flag
for each); `--config FILE.yaml` reads them from a file, `--print-config` writes the resolved
config (YAML) and exits without training. `sfv train SPEC` starts from a registered run spec
(`services/specs/`, `--specs` lists them): its settings, then the config file, then the flags.
The run directory records the spec, what was given on top and the commit (`run_spec.json`).
"""
from __future__ import annotations

import json
import logging


HELP = "train a controller that imitates a motion"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    from services.training.flags import add_config_flags

    p = sub.add_parser("train", help=HELP,
                       usage="sfv train [SPEC] --out DIR [--motion M] [--config FILE.yaml] [--resume] [settings ...]  "
                             "(sfv train --help lists every setting, --specs the specs)",
                       description="Train a controller that imitates a motion. Defaults come from the config dataclasses; "
                                   "`--print-config` shows every setting resolved.")
    p.add_argument("spec", nargs="?", default=None, metavar="SPEC",
                   help="a registered run spec (the configuration behind a reported number); flags override its settings")
    p.add_argument("--specs", action="store_true", help="list the registered run specs and exit")
    p.add_argument("--out", default=None, help="run directory: config, metrics.jsonl, TensorBoard events, checkpoints (required to train)")
    p.add_argument("--config", default=None, metavar="FILE.yaml", help="settings from a YAML file (the layout --print-config writes); flags given win")
    p.add_argument("--print-config", action="store_true", help="write the resolved config as YAML to stdout and exit")
    p.add_argument("--resume", action="store_true",
                   help="continue from the newest checkpoint in --out; safe settings given explicitly (budget, learning rate, "
                        "epochs, workers, addresses) win over the saved ones, the others are refused")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_config_flags(p)
    p.set_defaults(handler=run)


def requested_settings(args):
    """(the run spec or None, {config path: value} given, {config path: where it came from}):
    the spec's settings, then --config's, then the flags'."""
    from services.specs import run_spec
    from services.training.flags import given_settings, read_config_file

    spec = run_spec(args.spec, "train") if getattr(args, "spec", None) else None
    given = dict(spec.settings) if spec else {}
    flags = {path: f"spec {spec.name}: {path}" for path in given}
    if args.config is not None:
        from_file = read_config_file(args.config)
        given.update(from_file)
        flags.update({path: f"{args.config}: {path}" for path in from_file})
    from_flags, flag_names = given_settings(args)
    given.update(from_flags)
    flags.update(flag_names)
    return spec, given, flags


def build_config(args):
    """The run's TrainConfig: defaults (or the saved config on --resume), then the spec, --config and flags."""
    from pathlib import Path

    from learner.errors import SfvError
    from services.training.flags import chosen_presets, resolve
    from services.training.run_dir import CONFIG_FILE

    _, given, flags = requested_settings(args)
    given_out = given.pop("out", None)
    if args.out and given_out is not None and str(given_out) != str(args.out) and str(flags.get("job_id", "")).startswith(f"{args.config}:"):
        given.pop("job_id")  # another run's config.json as --config: this run derives its own ASI job id
    out = args.out or given_out
    if out is None and not args.print_config:
        raise SfvError("sfv train: --out is required (the run directory)")
    saved = Path(out) / CONFIG_FILE if out else None
    base = None
    if args.resume and saved is not None and saved.exists():
        base = json.loads(saved.read_text())
    config = resolve(given, flags, base, chosen_presets(args), resuming=base is not None)
    if out is not None:
        config.out = str(out)
    return config


def run(args) -> int:
    from services.console import attach_log_file
    from services.training.driver import Trainer
    from services.training.flags import config_yaml

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    if args.specs:
        from services.specs import spec_table

        print(spec_table("train"))
        return 0
    config = build_config(args)
    config.validate()  # a bad value is a one-line error before anything is written
    if args.print_config:
        print(config_yaml(config), end="")
        return 0
    attach_log_file(config.out)  # library output (Ray, gRPC, warnings) goes to RUN/sfv.log
    from services.specs.record import record_run_spec

    spec, given, _ = requested_settings(args)
    record_run_spec(config.out, spec, given)
    record = Trainer(config, resume=args.resume, progress=not args.quiet).run()
    summary = {k: record.get(k) for k in ("iteration", "samples", "normalized_return", "episode_length", "asi_version", "overall_samples_per_s")}
    print(json.dumps({"run": str(config.out), **summary}))
    return 0
