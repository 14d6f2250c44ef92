"""`sfv train`'s settings from one place: the config dataclasses' fields.

Every leaf field of `TrainConfig` (its own fields, `env`, `env.physics`, each env mode's
`env.sfv` / `env.movingcam`, `ppo`) becomes a flag named by its path (`--samples`,
`--env.horizon-s`, `--env.physics.physics-hz`, `--ppo.update-epochs`) whose type, choices and
help text come from the field, so a default is declared once, in the dataclass. The short
flags users know (`--epochs`, `--physics-hz`, `--hidden`, ...) are aliases of those paths
(`ALIASES`). A YAML file (`--config FILE.yaml`, the nested layout `--print-config` writes) sets
any field too. The env mode is `--env.mode`. Presets are named bundles of settings applied
under whatever is given (`REWARD_PRESETS`, `SETUP_PRESETS`): `--reward deepmimic|sfv_paper`
sets the sfv mode's reward, `--preset movingcam` the dynamic-camera paper's setup (the env
mode, residual targets, adaptive tuple sampling).

Precedence: the dataclass defaults, then the presets, then the config file, then the flags
given. With `--resume`, the run's saved config replaces the defaults; settings given
explicitly win where changing them mid-run is safe (`SAFE_ON_RESUME`: budget, learning rates,
epochs, workers, addresses, ...) and are refused with a one-line error where it is not
(network sizes, physics, reward, action and observation spaces), instead of being dropped
silently.

The mechanism is not the imitation config's alone: a `ConfigSchema` names a command's config
dataclass, its short flags, its resume rules and the fields it sets itself, and every function
here takes one (default: `sfv train`'s, `train_schema()`). `sfv task` (`TaskConfig`) and `sfv
distill` (`RecordConfig`, `MotorModuleConfig`) build their flags, YAML and resume refusals with it.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import types
import typing
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from learner.errors import SfvError
from learner.yaml_io import read_yaml

_MISSING = object()


@dataclass(frozen=True)
class Alias:
    """A short flag for one or more config paths (all set to the same value)."""

    flag: str
    paths: tuple[str, ...]
    type: Callable[[str], Any] | None = None  # parses and range-checks at parse time (argparse names the flag)
    help: str | None = None  # the (first) field's help when None
    const: Any = _MISSING  # a switch (store_const) setting the paths to this value
    metavar: str | None = None


def _positive(kind):
    """argparse type: a number of `kind` greater than zero."""
    def parse(text: str):
        try:
            value = whole_number(text) if kind is int else kind(text)
        except ValueError:
            value = None
        if value is None or not value > 0:
            raise argparse.ArgumentTypeError(f"expected a positive {kind.__name__}, got {text!r}")
        return value

    parse.__name__ = kind.__name__
    return parse


def _int_list(positive_only: bool, allow_none: bool):
    def parse(text: str) -> tuple[int, ...]:
        if allow_none and text.strip().lower() == "none":
            return ()
        try:
            values = tuple(int(part) for part in text.split(","))
        except ValueError:
            values = ()
        if not values or min(values) < 1:
            tail = ", or 'none'" if allow_none else ""
            raise argparse.ArgumentTypeError(f"expected positive integers separated by commas{tail}, got {text!r}")
        return values

    return parse


def _link_names(text: str) -> tuple[str, ...]:
    from actors.character.characters import CHARACTERS

    # Any body's links: the env config checks them against its own character's.
    links = tuple(dict.fromkeys(name for character in CHARACTERS.values() for name in character.link_names))
    if text.strip().lower() == "none":
        return ()
    names = tuple(part.strip() for part in text.split(",") if part.strip())
    unknown = [n for n in names if n not in links]
    if not names or unknown:
        raise argparse.ArgumentTypeError(f"expected link names separated by commas (of {', '.join(links)}), got {text!r}")
    return names


def _residual_scale(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"expected a scale >= 0 (0: absolute targets), got {text!r}")
    return value or None


ALIASES = (
    Alias("--character", ("env.character",)),
    Alias("--epochs", ("ppo.update_epochs",), _positive(int)),
    Alias("--policy-lr", ("ppo.policy_lr",), _positive(float)),
    Alias("--batch-size", ("ppo.batch_size",), _positive(int)),
    Alias("--hidden", ("ppo.policy_hidden", "ppo.value_hidden"), _int_list(True, False),
          "hidden layer sizes of the policy and value MLPs (paper: 1024,512)", metavar="N,N"),
    Alias("--serial", ("runner",), const="in_process", help="run the workers in this process, without Ray (= --runner in_process)"),
    Alias("--torch-threads", ("torch_threads",), _positive(int),
          "learner's torch threads (default: every core; workers wait while the learner updates)"),
    Alias("--physics-hz", ("env.physics.physics_hz",)),
    Alias("--no-early-termination", ("env.early_termination",), const=False,
          help="keep episodes going after a fall (rolls, getups)"),
    Alias("--ground-contact", ("env.ground_contact_links",), _link_names, metavar="LINK,LINK",
          help="links besides the feet allowed on the ground without a fall (default: the clip's DeepMimic setting; 'none': feet only)"),
    Alias("--action", ("env.action_parameterisation",)),
    Alias("--residual-scale", ("env.residual_action_scale",), _residual_scale,
          "residual PD targets: reference + this (rad) x action (default 0.5); 0 = absolute targets"),
    Alias("--reference-obs", ("env.reference_obs_steps",), _int_list(True, True), metavar="K,K",
          help="control steps ahead at which the policy observes the reference root (default 1,15); 'none' for SFV's observation"),
    Alias("--state-space", ("env.state_space",)),
    Alias("--scene", ("env.scene",), lambda text: None if text.strip().lower() == "none" else os.path.abspath(text), metavar="FILE.yaml"),
    Alias("--terrain", ("env.terrain",), lambda text: None if text.strip().lower() == "none" else text, metavar="KIND"),
    Alias("--terrain-difficulty", ("env.terrain_difficulty",), float, metavar="D"),
    Alias("--asi-std-scale", ("asi_initial_std_scale",), _positive(float)),
    Alias("--curriculum-samples", ("curriculum_samples",), _positive(int)),
    Alias("--no-root-sync", ("env.sync_root_per_cycle",), const=False,
          help="do not re-synchronise the reference root to the character each cycle"),
)
REWARD_PRESETS = ("deepmimic", "sfv_paper")  # `--reward`: the sfv mode's reward
SETUP_PRESETS = ("movingcam",)  # `--preset`: settings across the env and the learner
PRESET_FLAGS = {"preset:reward": "--reward", "preset:setup": "--preset"}  # argparse dest -> flag

# Changing these between a checkpoint and its continuation leaves the learner, its ASI
# distribution and the env consistent; anything else is refused on --resume.
SAFE_ON_RESUME = frozenset({
    "samples", "workers", "envs_per_worker", "runner", "max_policy_lag", "ppo.max_importance_weight", "device", "torch_threads", "ray_address",
    "asi_address", "asi_host", "redis_url", "asi_tls_ca", "asi_outage_s", "worker_timeout_s", "checkpoint_every",
    "keep_checkpoints", "plot_every", "plot_min_interval_s", "eval_every", "eval_episodes", "curriculum_start_s",
    "curriculum_samples", "asi_episodes_per_update", "asi_step_size", "asi_fall_weighting", "asi_phase_spread", "first_frame_share",
    "ppo.policy_lr", "ppo.value_lr", "ppo.update_epochs", "ppo.target_kl", "ppo.batch_size", "ppo.minibatch_size",
    "ppo.max_grad_norm", "ppo.clip_coef", "ppo.sgd_momentum", "ppo.tuple_sampling", "ppo.tuples_per_episode",
    "ppo.policy_lr_final", "ppo.action_std_final", "ppo.anneal_samples", "ppo.desired_kl",
    "env.start_velocity_median_rows",  # where episodes start, not what the networks or the reward are
})
SKIPPED = frozenset({"out"})  # its own flag: required unless --print-config or a config file gives it


@dataclass(frozen=True)
class ConfigSchema:
    """A command's settings: a config dataclass (with `to_dict` / `from_dict`) whose leaf fields
    become flags, YAML keys and resume rules."""

    root: Any  # the config class
    command: str = "sfv train"  # the prefix of its one-line errors
    aliases: tuple[Alias, ...] = ()
    safe_on_resume: frozenset[str] = frozenset()
    skipped: frozenset[str] = frozenset()  # fields the command sets itself (their flags are its own)
    presets: bool = False  # `--reward` / `--preset` (the imitation config's presets)
    list_nargs: bool = False  # list fields also take space-separated values (`--encoder-hidden 512 512`)


def train_schema() -> ConfigSchema:
    """`sfv train`'s schema (read at call time, so aliases and resume rules added here count)."""
    from services.training.config import TrainConfig

    return ConfigSchema(TrainConfig, "sfv train", ALIASES, SAFE_ON_RESUME, SKIPPED, presets=True)


# --------------------------------------------------------------------------- the fields
@dataclass(frozen=True)
class Leaf:
    path: str  # "env.physics.physics_hz"
    type: Any  # the resolved annotation
    default: Any
    help: str
    choices: tuple | None

    @property
    def flag(self) -> str:
        return "--" + self.path.replace("_", "-")


def leaves(cls=None, prefix: str = "") -> list[Leaf]:
    """Every leaf field of the config tree, depth first, in declaration order."""
    from services.training.config import TrainConfig

    cls = cls or TrainConfig
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        path, kind = prefix + f.name, hints[f.name]
        if dataclasses.is_dataclass(kind):
            out.extend(leaves(kind, path + "."))
            continue
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        out.append(Leaf(path, kind, default, f.metadata.get("help", ""), f.metadata.get("choices")))
    return out


def _optional(kind) -> tuple[Any, bool]:
    """(the type without None, whether None is allowed)."""
    if isinstance(kind, types.UnionType) or typing.get_origin(kind) is typing.Union:
        args = [a for a in typing.get_args(kind) if a is not type(None)]
        return args[0], len(args) < len(typing.get_args(kind))
    return kind, False


def whole_number(text: str) -> int:
    """'600', '500k', '2M', '1e6', '1_000' -> an int; ValueError for anything else (2.5k is 2500, 1.5 is not)."""
    raw = str(text).strip()
    scale = {"k": 1_000, "m": 1_000_000, "g": 1_000_000_000}.get(raw[-1:].lower(), 1)
    value = float((raw[:-1] if scale > 1 else raw).replace("_", "").replace(",", "")) * scale
    if not math.isfinite(value) or value != round(value):
        raise ValueError(f"not a whole number: {raw!r}")
    return int(round(value))


def _parser_for(leaf: Leaf) -> Callable[[str], Any]:
    base, nullable = _optional(leaf.type)
    if typing.get_origin(base) is tuple:
        item = typing.get_args(base)[0]

        def parse_tuple(text: str):
            if text.strip().lower() == "none":
                return ()
            try:
                return tuple(item(part.strip()) for part in text.split(",") if part.strip())
            except ValueError:
                raise argparse.ArgumentTypeError(f"expected {item.__name__}s separated by commas, got {text!r}") from None

        return parse_tuple

    def parse(text: str):
        if nullable and text.strip().lower() == "none":
            return None
        try:
            return whole_number(text) if base is int else base(text)
        except ValueError:
            if base is int:
                raise argparse.ArgumentTypeError(f"expected a whole number (600, 500k, 2M), got {text!r}") from None
            raise argparse.ArgumentTypeError(f"expected a {base.__name__}, got {text!r}") from None

    parse.__name__ = getattr(base, "__name__", "value")
    return parse


def _default_text(value) -> str:
    if isinstance(value, tuple):
        return ",".join(str(v) for v in value) or "none"
    return "none" if value is None else str(value)


# ------------------------------------------------------------------------- the parser
class _JoinedList(argparse.Action):
    """A list field given as several words (`512 512`) or one (`512,512`)."""

    def __call__(self, parser, namespace, values, option_string=None):
        try:
            setattr(namespace, self.dest, self.type_of_list(",".join(values)))
        except argparse.ArgumentTypeError as exc:
            parser.error(f"argument {option_string}: {exc}")


def add_config_flags(parser: argparse.ArgumentParser, skip: frozenset[str] = frozenset(),
                     title: str = "settings (each a config field; `--print-config` shows them all)",
                     default_text: dict[str, str] | None = None, schema: ConfigSchema | None = None) -> None:
    """Every config field as a flag (default SUPPRESS: only what the user gave appears in args);
    `skip`: config paths a command sets itself (`sfv pipeline`: the motion), with their aliases;
    `default_text`: {config path: the default the help shows} where the command has its own."""
    schema = schema or train_schema()
    by_path = {leaf.path: leaf for leaf in leaves(schema.root)}
    aliased = {a.paths[0]: a for a in schema.aliases if len(a.paths) == 1 and a.const is _MISSING}
    group = parser.add_argument_group(title)
    for leaf in by_path.values():
        if leaf.path in schema.skipped or leaf.path in skip:
            continue
        alias = aliased.get(leaf.path)
        names = list(dict.fromkeys(([alias.flag] if alias else []) + [leaf.flag]))
        shown = (default_text or {}).get(leaf.path, _default_text(leaf.default))
        help_text = f"{(alias.help if alias and alias.help else leaf.help)} [default: {shown}]".replace("%", "%%")
        base, _ = _optional(leaf.type)
        if base is bool:
            group.add_argument(*names, dest=leaf.path, action=argparse.BooleanOptionalAction, default=argparse.SUPPRESS, help=help_text)
            continue
        if schema.list_nargs and typing.get_origin(base) is tuple and not (alias and alias.type):
            action = group.add_argument(*names, dest=leaf.path, nargs="+", action=_JoinedList, default=argparse.SUPPRESS,
                                        help=help_text, metavar=leaf.path.rsplit(".", 1)[-1].upper())
            action.type_of_list = _parser_for(leaf)
            continue
        group.add_argument(*names, dest=leaf.path, type=(alias.type if alias and alias.type else _parser_for(leaf)),
                           choices=leaf.choices, default=argparse.SUPPRESS, help=help_text,
                           metavar=(alias.metavar if alias and alias.metavar else None if leaf.choices
                                    else leaf.path.rsplit(".", 1)[-1].upper()))
    for alias in schema.aliases:
        if alias.paths[0] in aliased and aliased[alias.paths[0]] is alias or skip.intersection(alias.paths):
            continue
        dest = "alias:" + alias.flag
        help_text = alias.help or by_path[alias.paths[0]].help
        if alias.const is not _MISSING:
            group.add_argument(alias.flag, dest=dest, action="store_const", const=alias.const, default=argparse.SUPPRESS, help=help_text)
        else:
            group.add_argument(alias.flag, dest=dest, type=alias.type, default=argparse.SUPPRESS, help=help_text, metavar=alias.metavar)
    if schema.presets:
        _add_preset_flags(group)


def _add_preset_flags(group) -> None:
    group.add_argument("--reward", dest="preset:reward", type=_reward_preset, default=argparse.SUPPRESS, metavar="{deepmimic,sfv_paper}",
                       help="the sfv mode's reward preset (default deepmimic: weighted-mean joint errors, root term, centre-of-mass "
                            "velocity; sfv_paper: the paper's sums and weights); --env.sfv.reward.* fields adjust it")
    group.add_argument("--preset", dest="preset:setup", choices=SETUP_PRESETS, default=argparse.SUPPRESS,
                       help="movingcam: the dynamic-camera paper's setup (--env.mode movingcam: its tracking reward and termination, "
                            "root path left to physics; residual targets; adaptive tuple sampling); --env.movingcam.* fields adjust it")


def _reward_preset(text: str) -> str:
    if text == "movingcam":  # the old spelling, when the reward flag also chose the mode
        raise argparse.ArgumentTypeError("movingcam is an env mode, not a reward: --preset movingcam "
                                         "(the mode with residual targets and adaptive tuple sampling) or --env.mode movingcam")
    if text not in REWARD_PRESETS:
        raise argparse.ArgumentTypeError(f"expected one of {', '.join(REWARD_PRESETS)}, got {text!r}")
    return text


def chosen_presets(args: argparse.Namespace) -> dict[str, str]:
    """{preset name: the flag that chose it} of the parsed command line."""
    return {getattr(args, dest): flag for dest, flag in PRESET_FLAGS.items() if hasattr(args, dest)}


def given_settings(args: argparse.Namespace, schema: ConfigSchema | None = None) -> tuple[dict[str, Any], dict[str, str]]:
    """({config path: value} the user gave on the command line, {config path: the flag used})."""
    schema = schema or train_schema()
    values, flags = {}, {}
    by_flag = {a.flag: a for a in schema.aliases}
    paths = {leaf.path for leaf in leaves(schema.root)}
    for dest, value in vars(args).items():
        if dest.startswith("alias:"):
            alias = by_flag.get(dest[len("alias:"):])
            for path in alias.paths if alias else ():
                values[path], flags[path] = value, alias.flag
        elif dest in paths:
            if dest in schema.skipped:
                continue
            values[dest] = value
            alias = next((a for a in schema.aliases if a.paths == (dest,) and a.const is _MISSING), None)
            flags[dest] = alias.flag if alias else "--" + dest.replace("_", "-")
    return values, flags


# ------------------------------------------------------------------------ config files
def read_config_file(path: str | Path, schema: ConfigSchema | None = None) -> dict[str, Any]:
    """{config path: value} from a YAML (or JSON) file in `--print-config`'s nested layout."""
    path = Path(path)
    document = read_yaml(path, "config file")
    if not isinstance(document, dict):
        raise SfvError(f"{path}: a config file holds a mapping of settings, got {type(document).__name__}")
    by_path = {leaf.path: leaf for leaf in leaves((schema or train_schema()).root)}
    flat: dict[str, Any] = {}

    def walk(node: dict, prefix: str) -> None:
        for key, value in node.items():
            name = _current_path(prefix + str(key))
            if isinstance(value, dict) and name not in by_path:
                walk(value, name + ".")
            elif name not in by_path:
                raise SfvError(f"{path}: unknown setting {name!r}")
            else:
                flat[name] = _checked(path, by_path[name], value)

    walk(document, "")
    return flat


# Settings that moved (a config file written before keeps working): old path prefix -> new.
MOVED_SETTINGS = {"env.reward": "env.sfv.reward", "env.tracking_termination_m": "env.sfv.tracking_termination_m"}


def _current_path(name: str) -> str:
    for old, new in MOVED_SETTINGS.items():
        if name == old or name.startswith(old + "."):
            return new + name[len(old):]
    return name


def _checked(source: Path, leaf: Leaf, value):
    base, nullable = _optional(leaf.type)
    if value is None and (nullable or typing.get_origin(base) is tuple):
        return value
    ok = {bool: lambda v: isinstance(v, bool), int: lambda v: isinstance(v, int) and not isinstance(v, bool),
          float: lambda v: isinstance(v, (int, float)) and not isinstance(v, bool), str: lambda v: isinstance(v, str)}
    if typing.get_origin(base) is tuple:
        item = typing.get_args(base)[0]
        if isinstance(value, (list, tuple)) and all(ok[item](v) for v in value):
            return tuple(value)
    elif ok[base](value):
        if leaf.choices and value not in leaf.choices:
            raise SfvError(f"{source}: {leaf.path} must be one of {', '.join(map(str, leaf.choices))}, got {value!r}")
        return float(value) if base is float else value
    raise SfvError(f"{source}: {leaf.path} must be {_type_name(leaf.type)}, got {value!r}")


def _type_name(kind) -> str:
    base, nullable = _optional(kind)
    name = f"a list of {typing.get_args(base)[0].__name__}" if typing.get_origin(base) is tuple else base.__name__
    return name + (" or null" if nullable else "")


# ------------------------------------------------------------------------- resolution
def resolve(given: dict[str, Any], flags: dict[str, str], base: dict | None = None,
            presets: str | dict[str, str] | None = None, resuming: bool = False, schema: ConfigSchema | None = None):
    """The config (a TrainConfig unless `schema` names another): `base` (a saved run config's dict;
    the defaults when None) with the presets (a name, or {name: the flag that chose it}) and then the
    given settings applied. On resume, an unsafe setting that differs from the run's is an SfvError
    naming its flag."""
    schema = schema or train_schema()
    root = schema.root
    config_dict = json.loads(json.dumps(_as_dict(root() if base is None else _from_dict(root, base))))
    for name, flag in ({presets: "--preset"} if isinstance(presets, str) else presets or {}).items():
        preset = preset_settings(name)
        given, flags = {**preset, **given}, {**dict.fromkeys(preset, flag), **flags}
    if resuming:
        _refuse_unsafe_changes(given, flags, config_dict, schema.safe_on_resume)
    for path, value in given.items():
        _set(config_dict, path, list(value) if isinstance(value, tuple) else value)
    if "ppo.batch_size" in given and "ppo.minibatch_size" not in given:  # a smaller batch than one minibatch
        config_dict["ppo"]["minibatch_size"] = min(config_dict["ppo"]["minibatch_size"], config_dict["ppo"]["batch_size"])
    try:
        return _from_dict(root, config_dict)
    except (ValueError, TypeError) as exc:
        raise SfvError(f"{schema.command}: {exc}") from None


def _as_dict(config) -> dict:
    return config.to_dict() if hasattr(config, "to_dict") else dataclasses.asdict(config)


def _from_dict(root, values: dict):
    """`root.from_dict`, or for a flat config without one its constructor (JSON lists back to tuples)."""
    if hasattr(root, "from_dict"):
        return root.from_dict(values)
    return root(**{k: tuple(v) if isinstance(v, list) else v for k, v in values.items()})


def preset_settings(name: str) -> dict[str, Any]:
    """{config path: value} of a named preset (`REWARD_PRESETS`, `SETUP_PRESETS`)."""
    from actors.envs.modes.sfv.reward import RewardConfig

    if name == "movingcam":
        return _movingcam_setup()
    if name not in REWARD_PRESETS:
        raise SfvError(f"unknown preset {name!r} (presets: {', '.join(REWARD_PRESETS + SETUP_PRESETS)})")
    reward = RewardConfig() if name == "deepmimic" else RewardConfig.sfv_paper()
    return {f"env.sfv.reward.{k}": v for k, v in dataclasses.asdict(reward).items()}


def _movingcam_setup() -> dict[str, Any]:
    """The env's movingcam mode with 002's reward and termination defaults, residual targets
    (eq. 1: q_target = q_ref + a) and adaptive tuple sampling (eq. 13), which comes with the
    mode in the paper."""
    from actors.envs.imitation_env import EnvConfig
    from actors.envs.modes.movingcam.tracking import MovingcamConfig

    preset = {"env.mode": "movingcam", "env.residual_action_scale": EnvConfig().residual_action_scale or 0.5,
              "ppo.tuple_sampling": "adaptive"}
    for leaf in leaves(MovingcamConfig, "env.movingcam."):
        preset[leaf.path] = leaf.default
    return preset


def _refuse_unsafe_changes(given: dict, flags: dict, saved: dict, safe: frozenset[str]) -> None:
    for path, value in given.items():
        if path in safe:
            continue
        old = _get(saved, path)
        new = list(value) if isinstance(value, tuple) else value
        if new != old:
            raise SfvError(f"{flags.get(path, path)}: cannot change on --resume (the run has {_default_text(_tuple(old))}, "
                           f"asked {_default_text(value)}); start a new run with another --out")


def _tuple(value):
    return tuple(value) if isinstance(value, list) else value


def _get(tree: dict, path: str):
    node = tree
    for key in path.split("."):
        node = node[key]
    return node


def _set(tree: dict, path: str, value) -> None:
    *parents, key = path.split(".")
    node = tree
    for name in parents:
        node = node[name]
    node[key] = value


def config_yaml(config) -> str:
    """The resolved config as YAML, in the layout `--config` reads."""
    import yaml

    return yaml.safe_dump(json.loads(json.dumps(config.to_dict())), sort_keys=False, width=120)
