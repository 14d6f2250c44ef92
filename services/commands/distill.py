"""`sfv distill EXPERTS --out MODULE`: record the experts' noisy rollouts and distil them into
the NPMP motor module (004 §3.3).

    sfv distill EXPERTS_DIR --out MODULE [--clips walk run ...] [--hold-out kick]
                [--dataset DATA_DIR] [--steps-per-clip 20000] [--updates 6000] [--resume]

EXPERTS_DIR holds one expert run directory per clip (`EXPERTS_DIR/<clip>/`, as `sfv train`
writes them). The dataset (`services/motor/dataset.py`) is recorded into --dataset (default
MODULE/dataset) unless one is there already; it is reused as it is (its clips are the ones
recorded). --hold-out leaves clips out of training (one-shot imitation of unseen clips,
`sfv one-shot`). The module directory is described in `services/motor/training.py`; a run cut
short continues with --resume.
"""
from __future__ import annotations


MODULE_SET_BY_DATASET = frozenset({"proprio_dim", "future_dim", "action_dim"})  # read from the dataset


def record_schema():
    from services.motor.recorder import RecordConfig
    from services.training.flags import ConfigSchema

    return ConfigSchema(RecordConfig, "sfv distill", list_nargs=True)


def module_schema():
    from learner.motor_config import MotorModuleConfig
    from services.training.flags import ConfigSchema

    return ConfigSchema(MotorModuleConfig, "sfv distill", skipped=MODULE_SET_BY_DATASET, list_nargs=True)


HELP = "distil expert controllers into a latent motor module (NPMP)"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    import argparse

    from services.training.flags import add_config_flags

    p = sub.add_parser("distill", help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    from services.specs import specs_for

    p.add_argument("experts", help="directory of expert run directories, one per clip")
    p.add_argument("--spec", choices=tuple(specs_for("distill")), default=None,
                   help="a registered distill spec (its clips, held-out clips and settings); flags given win")
    p.add_argument("--out", required=True, help="module directory")
    p.add_argument("--clips", nargs="+", default=None, help="clips to record (default: every expert with a checkpoint); <clip>_mirror: the mirrored expert of <clip>")
    p.add_argument("--hold-out", nargs="+", default=(), metavar="CLIP", help="recorded clips left out of training")
    p.add_argument("--dataset", default=None, help="dataset directory (default MODULE/dataset); recorded when absent")
    p.add_argument("--updates", type=int, default=6000, help="gradient steps (default 6000)")
    p.add_argument("--device", default="auto", help="torch device: auto (GPU when present), cpu, cuda, ...")
    p.add_argument("--torch-threads", type=int, default=None, help="CPU threads for torch (default: torch's)")
    p.add_argument("--resume", action="store_true", help="continue from the module directory's newest checkpoint")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    add_config_flags(p, title="dataset recording (RecordConfig)", schema=record_schema())
    add_config_flags(p, title="motor module (MotorModuleConfig)", schema=module_schema())
    p.set_defaults(handler=run)


SPEC_ARGUMENTS = ("clips", "hold_out")  # a distill spec's settings that are command-line arguments, not config fields


def _spec(args):
    from services.specs import run_spec

    return run_spec(args.spec, "distill") if getattr(args, "spec", None) else None


def _config(schema, args):
    """The schema's config: its defaults, then the spec's settings, then the flags given."""
    from services.training.flags import given_settings, leaves, resolve

    spec, paths = _spec(args), {leaf.path for leaf in leaves(schema.root)}
    given = {path: value for path, value in (spec.settings if spec else {}).items() if path in paths}
    flags = {path: f"spec {spec.name}: {path}" for path in given}
    from_flags, flag_names = given_settings(args, schema)
    given.update(from_flags)
    flags.update(flag_names)
    return resolve(given, flags, schema=schema)


def _spec_arguments(args) -> None:
    """The spec's clips and held-out clips where the command line gives none."""
    spec = _spec(args)
    if spec is not None:
        args.clips = args.clips or list(spec.settings.get("clips", ())) or None
        args.hold_out = args.hold_out or tuple(spec.settings.get("hold_out", ()))


def run(args) -> int:
    from pathlib import Path

    from learner.errors import SfvError
    from services.motor.dataset import MANIFEST
    from services.motor.recorder import expert_clips, record_dataset
    from services.motor.training import Distiller, DistillRun

    _spec_arguments(args)
    if args.updates < 1 or (args.torch_threads is not None and args.torch_threads < 1):
        raise SfvError("distill: --updates and --torch-threads must be >= 1")
    out = Path(args.out)
    dataset = Path(args.dataset) if args.dataset else out / "dataset"
    if out.exists() and any(out.glob("checkpoint_*.pt")) and not args.resume:
        raise SfvError(f"{out}: a module is being trained there (add --resume to continue)")
    if not (dataset / MANIFEST).is_file():
        manifest = record_dataset(Path(args.experts), expert_clips(Path(args.experts), args.clips), dataset, _config(record_schema(), args), progress=not args.quiet)
        print(f"dataset {dataset}: {manifest['steps']} steps of {len(manifest['clips'])} clips, {manifest['bytes'] / 2**20:.0f} MiB")
    config = _config(module_schema(), args)
    distiller = Distiller(dataset, out, config, tuple(args.hold_out),
                          DistillRun(args.updates, device=args.device, torch_threads=args.torch_threads, progress=not args.quiet))
    distiller.train()
    print(f"module {out}: trained on {', '.join(distiller.clips)} ({distiller.update} updates, {distiller.samples} steps seen)")
    return 0
