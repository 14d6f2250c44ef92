"""`sfv sim2sim POLICY.onnx`: replay an exported policy as a robot runtime would (issue 25, item 5).

    sfv sim2sim policy.onnx [--robot-xml g1.xml] [--physics-hz 1000] [--seconds 10] [--json OUT.json]
        a fresh MuJoCo model from the robot's raw MJCF with the policy's actuators (kp, kd, effort
        limit, armature from the file's metadata), physics at another rate than the training's,
        the observation computed from the metadata's layout, the action map applied; from the
        reference's first frame: seconds survived, mean joint-target error, torque saturation
        (services/export/sim2sim/; it uses onnxruntime, mujoco and numpy only)

`--robot-xml` defaults to the G1's cached g1.xml (`sfv models fetch --robot g1`) for a G1 policy
and to the project's generated MJCF for a humanoid3d one. Prints one JSON object (the report).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HELP = "replay an exported ONNX policy as a robot runtime would: a fresh model from the robot MJCF, another physics rate"  # the one line `sfv --help` lists


def register(sub) -> None:
    p = sub.add_parser("sim2sim", help=HELP, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("policy", help="an ONNX policy written by `sfv export RUN --onnx`")
    p.add_argument("--robot-xml", default=None,
                   help="the robot's raw MJCF (default: the cached G1 g1.xml for a g1 policy, the project's MJCF for humanoid3d)")
    p.add_argument("--physics-hz", type=float, default=1000.0, help="physics rate of the replay (training's is in the file)")
    p.add_argument("--seconds", type=float, default=10.0, help="episode length (capped by the reference's end)")
    p.add_argument("--json", default=None, help="also write the report here (atomically)")
    p.add_argument("--contacts", choices=("training", "xml"), default="training",
                   help="training: the trained floor pairs and friction, self-collision off; xml: the MJCF's own collision setup")
    p.add_argument("--fall-height", type=float, default=None, help="root height (m) below which the robot has fallen (default: half the first frame's)")
    p.set_defaults(handler=run)


def _check_args(args) -> None:
    from learner.errors import SfvError

    if not args.physics_hz > 0:
        raise SfvError(f"sim2sim: --physics-hz must be positive, got {args.physics_hz}")
    if not args.seconds > 0:
        raise SfvError(f"sim2sim: --seconds must be positive, got {args.seconds}")
    if args.json and not Path(args.json).resolve().parent.is_dir():
        raise SfvError(f"{args.json}: folder {Path(args.json).resolve().parent} does not exist")


def _default_robot_xml(character: str | None, folder: Path) -> Path:
    """The robot MJCF of a character: the G1's cache, or the humanoid3d's generated MJCF written into `folder`."""
    from learner.errors import SfvError

    if character == "g1":
        from actors.character.g1_model import XML_FILE, model_dir

        return model_dir() / XML_FILE
    if character == "humanoid3d":
        from actors.character.humanoid import build_mjcf

        path = folder / "humanoid3d.xml"
        path.write_text(build_mjcf())
        return path
    raise SfvError(f"sim2sim: no default robot MJCF for character {character!r}; give --robot-xml")


def run(args) -> int:
    import tempfile

    from learner.errors import SfvError
    from services.export.sim2sim import Sim2SimError, load_policy, run_sim2sim

    _check_args(args)
    try:
        with tempfile.TemporaryDirectory(prefix="sfv_sim2sim_") as folder:
            xml = args.robot_xml or _default_robot_xml(load_policy(args.policy).meta.get("character"), Path(folder))
            report = run_sim2sim(args.policy, xml, physics_hz=args.physics_hz, seconds=args.seconds, json_out=args.json,
                                 contacts=args.contacts, fall_height=args.fall_height)
    except Sim2SimError as exc:
        raise SfvError(str(exc)) from None
    if report.get("residual_wrench_dropped"):
        print("sfv sim2sim: warning: the policy was trained with a residual root force, which no robot has; "
              "replayed with its joints' actions alone", file=sys.stderr)
    print(json.dumps(report))
    return 0
