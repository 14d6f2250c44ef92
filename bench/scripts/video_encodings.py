"""The same video as other cameras write it: the reconstruction across encodings (issue 44).

    python bench/scripts/video_encodings.py [--video PATH] [--work DIR] [--out bench/results/video_encodings.json]

A user's camera writes another size, another frame rate, a mirrored selfie, a portrait phone
video whose pixels are stored sideways with a rotation flag; a pole stands between the camera and
the subject. The video (default: the Sports2D
park walk, `services/bench/public_videos.py`) is re-encoded with ffmpeg each way and
reconstructed as `sfv reconstruct VIDEO --serial` does it (pose track, subject, contacts,
reference check). Per encoding: the subject's frames, the root's travel and speeds, the mean and
worst reprojection error in pixels of the original's width, the reference check's line. The
encodings should agree with the original; where one does not, a cause is found (docs/video.md,
"Causes found" 7-9: an unseen frame placed at the middle of the walk, found at 25 fps; a second
behind the pole cut the motion; the frames of her stepping out from behind a tree).
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

RESULT = REPO / "bench" / "results" / "video_encodings.json"
# name -> ffmpeg arguments between the input and the output (the rotation flag is added after).
ENCODINGS = {
    "original": None,
    "640x360": ["-vf", "scale=640:-2"],
    "25fps": ["-r", "25"],
    "mirrored": ["-vf", "hflip"],
    "portrait_rotation_flag": ["-vf", "transpose=2"],
    # A pole in front of the scene (x 650-950 px of 1768, full height): the walker is hidden for
    # about a second as she passes behind it.
    "pole": ["-vf", "drawbox=x=650:y=0:w=300:h=994:color=0x2f4f2f@1:t=fill"],
}


def encode(video: Path, name: str, work: Path) -> Path:
    """The video re-encoded as `name` (x264, crf 18) in `work`; the original itself for "original"."""
    args = ENCODINGS[name]
    if args is None:
        return video
    out = work / f"{name}.mp4"
    if not out.is_file():
        ffmpeg = shutil.which("ffmpeg")
        if ffmpeg is None:
            raise SystemExit("video_encodings: ffmpeg not found (apt-get install ffmpeg)")
        subprocess.run([ffmpeg, "-v", "error", "-y", "-i", str(video), *args, "-c:v", "libx264", "-crf", "18",
                        str(work / f"{name}.tmp.mp4")], check=True)
        if name == "portrait_rotation_flag":  # pixels stored sideways, shown upright by the flag (a phone's portrait video)
            subprocess.run([ffmpeg, "-v", "error", "-y", "-i", str(work / f"{name}.tmp.mp4"), "-c", "copy",
                            "-metadata:s:v:0", "rotate=270", str(out)], check=True)
            (work / f"{name}.tmp.mp4").unlink()
        else:
            (work / f"{name}.tmp.mp4").rename(out)
    return out


def reconstruct(video: Path, out: Path) -> tuple[object, list[str], float]:
    """`sfv reconstruct VIDEO --out OUT --serial`: the motion, its printed lines, seconds."""
    from actors.motion.formats.io import load_motion

    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "services.cli", "reconstruct", str(video), "--out", str(out), "--serial"],
                          cwd=REPO, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"video_encodings: sfv reconstruct {video} failed: {done.stderr.strip().splitlines()[-1:]}")
    lines = [line.strip() for line in done.stdout.splitlines() + done.stderr.splitlines()
             if line.startswith(("subject", "reference check"))]
    return load_motion(out), lines, time.perf_counter() - started


def measure(motion, original_width: float) -> dict:
    extras = motion.extras
    times, root = motion.frame_times, motion.root_pos
    speed = np.linalg.norm(np.diff(root[:, :2], axis=0), axis=1) / np.diff(times)
    error = np.asarray(extras["reprojection_error_px"]) * original_width / float(extras["image_size"][0])
    start = int(extras["video_start_frame"])
    return {"frames": [start, start + motion.num_frames - 1], "fps": float(extras["fps"]),
            "travel_m": float(np.linalg.norm(root[-1, :2] - root[0, :2])), "seconds": float(times[-1]),
            "root_speed_median_mps": float(np.median(speed)), "root_speed_max_mps": float(speed.max()),
            "reprojection_mean_px": float(error.mean()), "reprojection_max_px": float(error.max()),
            "reference_check": str(extras.get("reference_check", ""))}


def main(argv=None) -> int:
    from learner.atomic_io import atomic_write_json
    from services.bench.public_videos import fetch_public_video

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--video", default=None, help="a video file (default: the Sports2D park walk, fetched and checked)")
    parser.add_argument("--work", default="runs/video_encodings", help="the encodings and their motions")
    parser.add_argument("--encodings", default=",".join(ENCODINGS), help="comma-separated; rows of others already in --out are kept")
    parser.add_argument("--out", default=str(RESULT))
    args = parser.parse_args(argv)
    video = Path(args.video) if args.video else fetch_public_video("sports2d_demo")
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    from services.pose.video import probe_video

    width = probe_video(video).width
    out = Path(args.out)
    rows = json.loads(out.read_text()).get("encodings", {}) if out.is_file() else {}  # other encodings' rows are kept
    for name in args.encodings.split(","):
        motion, lines, seconds = reconstruct(encode(video, name, work), work / f"{name}.npz")
        rows[name] = {**measure(motion, width), "lines": lines, "wall_s": round(seconds, 1)}
        print(json.dumps({name: rows[name]}), flush=True)
    atomic_write_json(args.out, {"bench": "video_encodings", "video": str(video), "original_width_px": width,
                                 "encodings": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
