"""`sfv pipeline VIDEO --out DIR`: video -> pose (Ray tasks) -> reconstruction (a Ray task) -> training.

One Ray job graph on one Ray session: the pose tasks' track feeds the reconstruction task,
whose motion (written to DIR/motion.npz by `sfv reconstruct`'s own path, `contacts/video_motion.py`:
the learned foot contacts it was fitted to, video_start_frame and the video's other extras)
the training driver imitates with its rollout actors (run directory DIR/train). Then the controller is played against the video
(`services/pipeline/finish.py`): its best checkpoint from the clip's first frame for the clip's
length, written as DIR/simulated.npz, simulated.bvh, video.mp4 (video | reference | simulation),
overlay_strip.png (the simulation over the video through the reconstruction's camera) and
report.json (fall, return, joint error, foot skating, penetration, reprojection error).
Where that controller needs its residual root force (it completes the clip, and falls with the help
at zero), a second training makes the body alone follow its rollout, into DIR/alone with the same
files (`services/pipeline/body_alone.py`; `--body-alone auto|always|off`); DIR/report.json's
`controller` line says which controller the pipeline gives and how it ends without help.
`--finish-only` plays the controllers against the video again on a finished DIR (another
`--checkpoint`); `--resume` continues an interrupted DIR where it stopped.

`--camera moving [--scene boxes.yaml]` (002 §5-6): the motion is written root-free, then
`services/scene_fit` trains its windows' policies in 002's tracking mode (each window a run
directory DIR/windows/w<n>/train with Ray rollout actors), fits the scene by SLSQP and rolls the
policies out in it: DIR/simulated.npz, simulated.bvh, scene_fitted.yaml, scene_fit.json and
simulated.mp4 (the simulation beside the video). `_moving_pipeline.py` has that path.
"""
from __future__ import annotations

from pathlib import Path

HELP = "reconstruct a motion from a video, then train a controller for it"  # the one line `sfv --help` lists (without importing the command)


def register(sub) -> None:
    from services.commands._person_args import add_person_arguments
    from services.commands._pipeline_settings import PIPELINE_DEFAULT_TEXT, PIPELINE_SETS
    from services.training.flags import add_config_flags

    p = sub.add_parser("pipeline", help=HELP,
                       usage="sfv pipeline VIDEO --out DIR [--person ID | --person-at X,Y@FRAME] [--frames A:B] [--camera static|moving] "
                             "[--scene BOXES.yaml] [--resume] [--body-alone auto|always|off] [--helped-max-samples N] [--body-alone-max-samples N] "
                             "[--checkpoint best|latest] [--finish-only] "
                             "[--config FILE.yaml] [training settings ...]  (sfv pipeline --help lists every setting)",
                       description="Reconstruct a motion from a video, then train a controller for it. The training "
                                   "settings are `sfv train`'s (the config dataclasses' fields, same defaults).")
    p.add_argument("video", type=Path, help="input video of one person")
    p.add_argument("--out", type=Path, required=True, help="output directory: track.npz, motion.npz, train/, then (static "
                   "camera) simulated.npz, simulated.bvh, video.mp4, overlay_strip.png, report.json")
    add_person_arguments(p)
    p.add_argument("--pose-models", default=None, help="BlazePose model directory (default: `sfv models fetch` cache)")
    p.add_argument("--iterations", type=int, default=None, help="reconstruction optimiser steps")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--camera", choices=("static", "moving"), default="static",
                   help="static: SFV's root path from the image (default); moving: root-free motion, 002's tracking, "
                        "windows, scene fit and a final rollout (samples per window: --samples)")
    p.add_argument("--scene", type=Path, default=None, help="with --camera moving: the boxes' scene file (YAML) whose "
                   "positions and heights are fitted within their domains")
    p.add_argument("--resume", action="store_true",
                   help="continue an interrupted run in --out: its motion.npz kept, a training that stopped part way "
                        "from its checkpoint (with its saved settings), a finished one kept; with --camera moving, "
                        "finished windows kept")
    p.add_argument("--body-alone", choices=("auto", "always", "off"), default=None,
                   help="static camera: a second training of the body alone (no residual root force) on the helped "
                        "controller's rollout, into DIR/alone (services/pipeline/body_alone.py). auto (default): "
                        "when the helped controller completes the clip but falls without its help; always: also when "
                        "it does not fall; off: never")
    p.add_argument("--helped-max-samples", type=int, default=None, metavar="N",
                   help="static camera: where the first controller falls from the first frame with its help (or topples "
                        "at the clip's end) after its --samples, it trains on by half as many again, and again, up to N "
                        "samples (default: the larger of twice --samples and 800 k per second of clip; equal to --samples: never)")
    p.add_argument("--body-alone-max-samples", type=int, default=None, metavar="N",
                   help="static camera: where the body-alone controller falls (or topples at the clip's end) after its "
                        "--samples, the stage trains on by half as many again, and again, up to N samples (default: the "
                        "larger of twice --samples and 800 k per second of clip; equal to --samples: never)")
    p.add_argument("--checkpoint", choices=("best", "latest"), default="best",
                   help="the checkpoint played against the video: best (best.pt, the best periodic evaluation; the "
                        "newest when the run has none) or latest")
    p.add_argument("--finish-only", action="store_true",
                   help="static camera: only play DIR/train's controller (and DIR/alone/train's, where there is one) "
                        "against the video again (DIR/motion.npz and DIR/train from an earlier run), rewriting "
                        "simulated.npz, simulated.bvh, video.mp4, overlay_strip.png and report.json")
    p.add_argument("--config", default=None, metavar="FILE.yaml",
                   help="training settings from a YAML file (the layout `sfv train --print-config` writes); flags given win")
    add_config_flags(p, skip=PIPELINE_SETS, title="training settings (`sfv train`'s; each a config field)",
                     default_text=PIPELINE_DEFAULT_TEXT)
    p.set_defaults(handler=run)


def run(args) -> int:
    if args.camera == "moving" and args.finish_only:
        from learner.errors import SfvError

        raise SfvError("--finish-only is for --camera static (the moving path writes its outputs itself; --resume continues it)")
    if args.camera == "moving":
        from services.commands._moving_pipeline import run_moving

        chosen = [f for f, v in (("--person", args.person), ("--person-at", args.person_at), ("--frames", args.frames),
                                 ("--body-alone", args.body_alone),
                                 ("--body-alone-max-samples", args.body_alone_max_samples),
                                 ("--helped-max-samples", args.helped_max_samples)) if v is not None]
        if chosen:
            from learner.errors import SfvError

            raise SfvError(f"{chosen[0]} is for --camera static (the moving path follows the default subject)")

        return run_moving(args)
    from learner.errors import SfvError

    if args.scene is not None:
        raise SfvError("--scene needs --camera moving")
    args.body_alone = args.body_alone or "auto"
    if args.finish_only and args.resume:
        raise SfvError("--finish-only and --resume: choose one (--resume finishes what it trains)")
    from services.commands._static_pipeline import run_finish_only, run_static

    if args.finish_only:
        return run_finish_only(args)
    return run_static(args)
