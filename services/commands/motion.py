"""`sfv motion`: inspect and convert reference motions.

    sfv motion check MOTION [--physics-hz HZ]      (MOTION may be a robot motion: its own robot plays it)
    sfv motion convert IN --out OUT.npz [--rig auto|NAME|MAP.yaml] [--up +y] [--forward +z] [--units cm] [--loop auto]
    sfv motion convert IN --character g1 --out IN_g1.npz [--fps F]
    sfv motion bend MOTION --yaw-rate DEG_PER_S --seconds S --out OUT.npz

MOTION is a DeepMimic clip name (`deepmimic:walk`) or a path (.npz, DeepMimic JSON or BVH).
A BVH from another rig is retargeted onto the humanoid (`actors/motion/formats/retarget.py`); `convert`
then adds what the retargeting did to its JSON (`retarget`: rig, axes, units, clipped
angles, floor shift, penetration before/after, foot skating of source and result).
`convert --character g1` retargets the clip onto the Unitree G1 (`actors/motion/robot_retarget.py`;
the robot's model comes from `sfv models fetch --robot g1`) and writes a robot motion
(`actors/motion/robot_motion.py`) and, beside it, OUT.json: per-body position error after
scaling, limit clipping, penetration and foot skating of the source, the scaled source and the
robot (the same figures as the result lines it prints).
`check` loads the clip, builds the imitation env on it and prints one JSON object: the
clip's summary and `playback_reward`, the mean reward when the simulated character is put
exactly on the reference at every control step of one pass of the clip. A value below 1
means the reward's reference features and the simulated features disagree (a kinematics
or state-layout bug), not that the clip is hard. `convert` writes the project's .npz.
`bend` plays a (looped) clip along a path turning at a constant rate (`actors/motion/bend.py`):
the turning walk the motor module's vocabulary needs (NPMP, 004 §3.4).
"""
from __future__ import annotations

import argparse
import json
import math

from learner.errors import SfvError


HELP = "check or convert a reference motion"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers) -> None:
    parser = subparsers.add_parser("motion", help=HELP,
                                   description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = parser.add_subparsers(dest="motion_action", required=True)

    check = actions.add_parser("check", help="validate a motion and print its summary and playback reward as JSON")
    check.add_argument("motion", help="deepmimic:<clip>, a .npz / DeepMimic JSON / BVH motion, or a robot motion file")
    check.add_argument("--physics-hz", type=float, default=None,
                       help="MuJoCo step rate (a whole multiple of the 30 Hz control rate; default: the env's)")
    check.set_defaults(handler=run_check)

    convert = actions.add_parser("convert", help="load any supported motion format and save it as sfv .npz")
    convert.add_argument("motion", help="deepmimic:<clip> or a path to a .npz / DeepMimic JSON motion")
    convert.add_argument("--out", required=True, help="where to write the .npz (written atomically)")
    convert.add_argument("--character", choices=("humanoid3d", "g1"), default="humanoid3d",
                         help="the body to convert for: humanoid3d (the project's .npz) or g1 (retargeted onto the "
                              "Unitree G1; a robot motion .npz and OUT.json with the retargeting report)")
    convert.add_argument("--fps", type=float, default=None, help="with --character g1: output frame rate (default: the clip's)")
    _add_bvh_flags(convert)
    convert.set_defaults(handler=run_convert)

    bend = actions.add_parser("bend", help="play a clip along a path turning at a constant rate; save it as .npz")
    bend.add_argument("motion", help="deepmimic:<clip> or a motion file (a loop plays for --seconds)")
    bend.add_argument("--yaw-rate", type=float, required=True, help="turning rate in degrees per second (positive: to the left)")
    bend.add_argument("--seconds", type=float, required=True, help="length of the bent clip (s)")
    bend.add_argument("--name", default=None, help="the clip's name (default: <motion>_turn<rate>)")
    bend.add_argument("--out", required=True, help="where to write the .npz (written atomically)")
    bend.set_defaults(handler=run_bend)


def _add_bvh_flags(parser) -> None:
    from actors.motion.formats.bvh_units import AXES, UNIT_METRES
    from actors.motion.formats.rigs import PRESET_NAMES

    group = parser.add_argument_group("BVH input (ignored by other formats)")
    group.add_argument("--rig", default="auto", help=f"auto (detect from joint names), a preset ({', '.join(PRESET_NAMES)}) "
                       "or a YAML/JSON map 'source joint: humanoid target'")
    group.add_argument("--up", choices=tuple(AXES), default=None, help="the file's up axis (default: detected)")
    group.add_argument("--forward", choices=tuple(AXES), default=None, help="the rest pose's facing axis (default: detected)")
    group.add_argument("--units", choices=tuple(UNIT_METRES), default=None, help="the file's length unit (default: from the skeleton's size)")
    group.add_argument("--loop", choices=("auto", "yes", "no"), default="auto", help="mark the clip cyclic (auto: last pose near the first)")


def _env_config(physics_hz: float | None):
    from actors.character.humanoid import PhysicsConfig
    from actors.envs.imitation_env import EnvConfig

    config = EnvConfig()
    if physics_hz is None:
        return config
    if not math.isfinite(physics_hz) or physics_hz <= 0:
        raise SfvError(f"--physics-hz {physics_hz:g}: must be a positive number of steps per second")
    config = EnvConfig(physics=PhysicsConfig(physics_hz=physics_hz))
    try:
        config.substeps  # validates the rate against the control rate
    except ValueError as exc:
        raise SfvError(f"--physics-hz {physics_hz:g}: {exc}") from None
    return config


def playback_reward(env) -> float:
    """Mean reward over one pass of the clip with the character set onto the reference."""
    total = 0.0
    rows = env.track.start_steps
    for row in range(rows):
        env.set_reference_state(row)
        total += env.reward_at(row)
    return total / rows


def _check_subject(motion_arg: str, config):
    """The motion to check and the env config for its body: a robot motion file drives its own robot."""
    import dataclasses

    from actors.motion.formats.io import load_motion
    from actors.motion.robot_motion import is_robot_motion, load_robot_motion

    if is_robot_motion(motion_arg):
        robot = load_robot_motion(motion_arg)
        return robot, dataclasses.replace(config, character=robot.character)
    return load_motion(motion_arg), config


def run_check(args: argparse.Namespace) -> int:
    from actors.envs.imitation_env import ImitationEnv

    motion, config = _check_subject(args.motion, _env_config(args.physics_hz))
    env = ImitationEnv(motion, config)
    report = dict(motion.summary())
    report["physics_hz"] = config.physics.physics_hz
    report["control_hz"] = config.control_hz
    report["playback_reward"] = round(playback_reward(env), 6)
    if env.motion.loop:  # a loop whose last pose is not its first jumps at every wrap (actors/motion/loop_closure.py)
        from actors.motion.loop_closure import wrap_mismatch

        report["loop_wrap_mismatch_rad"] = round(float(wrap_mismatch(env.motion).max()), 4)
    print(json.dumps(report))
    return 0


def run_convert(args: argparse.Namespace) -> int:
    from actors.motion.formats.io import check_motion, is_bvh_file, load_motion, resolve_motion_path, save_motion

    if args.character == "g1":
        return _convert_to_g1(args)
    if args.fps is not None:
        raise SfvError("--fps applies to --character g1 only")
    retarget_report = None
    if not args.motion.startswith("deepmimic:") and is_bvh_file(args.motion):
        from actors.motion.formats.bvh_import import import_bvh
        from actors.motion.formats.retarget import RetargetOptions

        loop = {"auto": None, "yes": True, "no": False}[args.loop]
        path = resolve_motion_path(args.motion)
        motion, retarget_report = import_bvh(path, args.rig, RetargetOptions(args.up, args.forward, args.units, loop))
        check_motion(path, motion)
    elif args.rig != "auto" or args.up or args.forward or args.units or args.loop != "auto":
        raise SfvError(f"{args.motion}: --rig, --up, --forward, --units and --loop apply to BVH input only")
    else:
        motion = load_motion(args.motion)
    try:
        path = save_motion(motion, args.out)
    except OSError as exc:
        raise SfvError(f"{args.out}: cannot write motion ({exc.strerror or exc})") from None
    report = dict(motion.summary())
    report["out"] = str(path)
    if retarget_report is not None:
        from actors.motion.formats.bvh_import import FILE_REPORT

        report["bvh"] = retarget_report.pop(FILE_REPORT)  # frames declared / read, each tolerated quirk
        report["retarget"] = retarget_report
    print(json.dumps(report))
    return 0


def _load_any(args: argparse.Namespace):
    """The source clip: a BVH through the importer (rig flags apply), anything else by name."""
    from actors.motion.formats.io import check_motion, is_bvh_file, load_motion, resolve_motion_path

    if not args.motion.startswith("deepmimic:") and is_bvh_file(args.motion):
        from actors.motion.formats.bvh_import import import_bvh
        from actors.motion.formats.retarget import RetargetOptions

        loop = {"auto": None, "yes": True, "no": False}[args.loop]
        path = resolve_motion_path(args.motion)
        motion, _ = import_bvh(path, args.rig, RetargetOptions(args.up, args.forward, args.units, loop))
        check_motion(path, motion)
        return motion
    if args.rig != "auto" or args.up or args.forward or args.units or args.loop != "auto":
        raise SfvError(f"{args.motion}: --rig, --up, --forward, --units and --loop apply to BVH input only")
    return load_motion(args.motion)


def g1_result_lines(report: dict) -> list[str]:
    """The retargeting report as the lines `convert --character g1` prints."""
    error, pen, skate, clip = (report["key_body_error_m"], report["penetration_m"], report["skating_m_s"],
                               report["limit_clipping"])
    return [
        f"key-body error after scaling (x{report['scale']:.3f}): mean {100 * error['mean']:.2f} cm, "
        f"max {100 * error['max']:.2f} cm ({error['worst_body']})",
        f"joint limits: {clip['joint_frames_at_limit']} joint-frames at a limit"
        + (f" ({', '.join(f'{k} {v}' for k, v in clip['joints'].items())})" if clip["joints"] else ""),
        f"penetration: source {100 * pen['source']:.2f} cm, scaled source {100 * pen['scaled_source']:.2f} cm, "
        f"robot {100 * pen['robot']:.2f} cm",
        f"foot skating: source {100 * skate['source']:.1f} cm/s, scaled source {100 * skate['scaled_source']:.1f} cm/s, "
        f"robot {100 * skate['robot']:.1f} cm/s",
    ]


def _convert_to_g1(args: argparse.Namespace) -> int:
    from pathlib import Path

    from actors.motion.robot_motion import save_robot_motion
    from actors.motion.robot_retarget import retarget_to_g1
    from learner.atomic_io import atomic_write_json

    if args.fps is not None and not (math.isfinite(args.fps) and 1 <= args.fps <= 1000):
        raise SfvError(f"--fps must be a frame rate in [1, 1000], got {args.fps}")
    motion = _load_any(args)
    robot_motion, report = retarget_to_g1(motion, args.motion, args.fps)
    out = Path(args.out)
    report_path = out.with_suffix(".json")
    try:
        save_robot_motion(robot_motion, out)
        atomic_write_json(report_path, {**robot_motion.summary(), "out": str(out), "retarget": report})
    except OSError as exc:
        raise SfvError(f"{args.out}: cannot write motion ({exc.strerror or exc})") from None
    for line in g1_result_lines(report):
        print(line)
    print(f"wrote {out} ({robot_motion.num_frames} frames at {robot_motion.fps:.3g} fps, {robot_motion.summary()['duration']:.2f} s "
          f"of motion, retargeted in {report['seconds']:.1f} s) and {report_path}")
    return 0


def run_bend(args: argparse.Namespace) -> int:
    from actors.motion.bend import bend_motion
    from actors.motion.formats.io import load_motion, save_motion

    if not (math.isfinite(args.seconds) and 0 < args.seconds <= 600):
        raise SfvError(f"--seconds must be in (0, 600], got {args.seconds}")
    if not (math.isfinite(args.yaw_rate) and abs(args.yaw_rate) <= 360):
        raise SfvError(f"--yaw-rate must be a number of degrees per second within +-360, got {args.yaw_rate}")
    motion = bend_motion(load_motion(args.motion), math.radians(args.yaw_rate), args.seconds, args.name)
    try:
        path = save_motion(motion, args.out)
    except OSError as exc:
        raise SfvError(f"{args.out}: cannot write motion ({exc.strerror or exc})") from None
    print(json.dumps({**motion.summary(), "out": str(path)}))
    return 0
