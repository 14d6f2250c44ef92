"""`sfv experts`: train a tracking expert per clip (one resumable Ray job), and tabulate them.

    sfv experts CLIPS... --out DIR [--character humanoid3d|g1] [--samples N] [--parallel K] [--table]
    sfv experts table DIR [CLIP...] [--table-out OUT] [--episodes E] [--parallel K]   (default: every trained clip and its mirror)
    sfv experts render DIR CLIP --video FILE.mp4 [--seconds T]   (CLIP may be <clip>_mirror)

CLIPS are DeepMimic clip names, motion files (a clip named by the file's stem: a bent walk from
`sfv motion bend`), `<clip>_mirror` (served by symmetry, not trained) or `all`.
--character g1 trains them on the Unitree G1 (the clips retargeted at load); an experts
directory holds one body's experts; mirrored experts act through their original's on either body.
"""
from __future__ import annotations

import json
from pathlib import Path


HELP = "train one tracking expert per clip (resumable Ray job), or `table DIR` to evaluate them"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    from actors.character.characters import CHARACTER_NAMES
    from services.experts.job import DEFAULT_SAMPLES, HUMANOID
    from services.experts.table import CURVE_SECONDS, DEFAULT_EPISODES, DEFAULT_STARTS

    p = sub.add_parser("experts", help=HELP,
                       usage="sfv experts CLIPS... --out DIR [--character humanoid3d|g1] [--samples N] [--parallel K] [--table]\n"
                             "       sfv experts table DIR [CLIP...] [--table-out OUT] [--episodes E] [--parallel K]\n"
                             "       sfv experts render DIR CLIP --video FILE.mp4 [--seconds T]",
                       description="Tracking experts (NPMP, 004 §3.2): one standard run directory DIR/<clip>/ per clip, "
                                   "finished clips skipped, partial ones resumed; <clip>_mirror comes from <clip>'s expert by "
                                   "left/right symmetry (on either body); `all` is every DeepMimic clip and its mirror; a motion file "
                                   "(.npz, .json, .bvh) is a clip named by its stem. "
                                   "--character g1 trains the experts on the Unitree G1 (a directory holds one body's experts). "
                                   "`table DIR` writes "
                                   "DIR/experts.json, experts.md and the Fig. 3B plot experts_tracking.png.")
    p.add_argument("clips", nargs="+", metavar="CLIP", help="clip names, <clip>_mirror, all; or `table DIR`")
    p.add_argument("--out", default=None, help="experts directory (one run directory per clip)")
    p.add_argument("--character", default=HUMANOID, choices=CHARACTER_NAMES,
                   help="the body every expert of --out trains (default humanoid3d; g1: the Unitree G1, `sfv models fetch --robot g1`, "
                        "the clips retargeted at load, <clip>_mirror by the G1's hinge mirror signs); "
                        "a directory of the other body's experts is refused")
    p.add_argument("--samples", type=int, default=DEFAULT_SAMPLES, help="sample budget of each training (a clip with that many is finished)")
    p.add_argument("--curriculum-samples", type=int, default=None, help="episode-length curriculum of new trainings (default: half the budget)")
    p.add_argument("--parallel", type=int, default=None, help="trainings (or evaluations) at once, one core each (default: every core)")
    p.add_argument("--table", action="store_true", help="after training, write the expert table of --out")
    p.add_argument("--table-out", default=None, help="folder for the table's files (default: the experts directory)")
    p.add_argument("--episodes", type=int, default=DEFAULT_EPISODES, help="strict evaluation episodes per expert in the table")
    p.add_argument("--starts", type=int, default=DEFAULT_STARTS, help="starts through each clip for the tracking curve (Fig. 3B)")
    p.add_argument("--curve-seconds", type=float, default=CURVE_SECONDS, help="longest rollout of the tracking curve (s)")
    p.add_argument("--video", default=None, help="render: the MP4 to write (the expert beside its reference ghost)")
    p.add_argument("--seconds", type=float, default=None, help="render: seconds per episode (default: the episode's horizon)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(handler=run)


def run(args) -> int:
    import logging

    from learner.errors import SfvError
    from services.experts.job import HUMANOID, default_parallel, expand_clips, known_runs, run_experts_job
    from services.experts.library import directory_character
    from services.experts.table import build_table, markdown_table

    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    for name in ("samples", "episodes", "starts"):
        if getattr(args, name) <= 0:
            raise SfvError(f"sfv experts: --{name} must be positive, got {getattr(args, name)}")
    if args.parallel is not None and args.parallel <= 0:
        raise SfvError(f"sfv experts: --parallel must be positive, got {args.parallel}")
    parallel = args.parallel or default_parallel()
    table_args = dict(episodes=args.episodes, starts=args.starts, curve_seconds=args.curve_seconds, parallel=parallel,
                      progress=not args.quiet, out=args.table_out)
    if args.clips[0] == "render":
        return render(args)
    if args.clips[0] == "table":
        if len(args.clips) < 2:
            raise SfvError("sfv experts table: give the experts directory (sfv experts table DIR [CLIP...])")
        # The body is the runs' own (config.json): a mirror is refused only for a body without hinge mirror signs.
        found = directory_character(args.clips[1])
        clips = (expand_clips(args.clips[2:], found[0] if found else HUMANOID, known_runs(Path(args.clips[1])))
                 if len(args.clips) > 2 else None)
        print(markdown_table(build_table(args.clips[1], clips, **table_args)), end="")
        return 0
    if args.out is None:
        raise SfvError("sfv experts: --out DIR is required (the experts directory)")
    summary = run_experts_job(args.clips, args.out, args.samples, parallel, curriculum_samples=args.curriculum_samples,
                              progress=not args.quiet, character=args.character)
    states = {clip: s["state"] for clip, s in summary["status"].items()}
    print(json.dumps({"out": args.out, "character": summary["character"], "status": states}))
    if args.table:
        print(markdown_table(build_table(args.out, **table_args)), end="")
    return 0


class _DeterministicExpert:
    """An expert as the render code's policy: act(obs, deterministic=True) -> (actions, None)."""

    def __init__(self, expert):
        self.expert = expert

    def act(self, obs, deterministic: bool = True, **_):
        return self.expert.act(obs), None


def render(args) -> int:
    """Film one expert (trained or mirrored) deterministically from a start at phase 0."""
    from services.render.gl import select_backend

    select_backend()  # the GL backend the machine has, before mujoco loads; none is one line
    from learner.errors import SfvError  # noqa: E402
    from services.experts.library import load_expert
    from services.render.movie import RenderConfig, render_policy
    from services.render.video_writer import check_video_path

    if len(args.clips) != 3 or args.video is None:
        raise SfvError("sfv experts render: give DIR CLIP and --video FILE.mp4")
    check_video_path(args.video)
    expert = load_expert(args.clips[1], args.clips[2], max_batch=1)
    env = expert.make_env()
    config = RenderConfig(episodes=1, seconds=args.seconds, init="fsi", label=f"expert {expert.name} (blue: reference)")
    summary = render_policy(_DeterministicExpert(expert), env, args.video, config)
    print(json.dumps({**summary, "expert": expert.name, "motion": expert.motion}))
    return 0
