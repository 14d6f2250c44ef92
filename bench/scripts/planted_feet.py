"""Does a foot standing still in a static camera's picture mark a contact the network misses? Issue 44.

    python bench/scripts/planted_feet.py [--tracks DIR] [--clip VIDEO=TRACK ...] [--model DIR]
                                         [--out bench/results/planted_feet.json]

Scores the foot contacts the static pipeline fits its reference to, per foot and frame, three ways:
the contact network's flags (probability >= 0.5), those with the planted feet added
(`services/contacts/planted.py`), and the reconstruction's final flags (planted feet and the
walker's missed support, `support.py`, as `sfv pipeline` has them). Ground truth:
- the Pose2Sim balancing trial's four cameras against its markers, and the two-people trial's
  against the man's (P2) markers (`tests/pose2sim_truth.marker_contacts`); their pose tracks
  are DIR/{balancing,two_people}_camNN.npz (`sfv pose VIDEO --out ... --serial`), estimated here
  when absent;
- clips labelled by looking (`LABELLED`, keyed by the video's SHA-256, with where the file comes
  from): `--clip VIDEO=TRACK` scores one when its file matches.

`--model DIR` scores another contact network (`sfv contacts-train --out DIR`) in place of the shipped one.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

RESULT = REPO / "bench" / "results" / "planted_feet.json"
SHARED = REPO.parent / "shared" / "data" / "video"
TRIALS = {"balancing": ("pose2sim_balancing", "S00_P00_T01_BalancingTrial_0-100_filt_butterworth.trc"),
          "two_people": ("pose2sim_two_people", "S00_P01_T02_Participants1-2_P2_0-100_filt_butterworth.trc")}

# Contacts (right, left) of clips labelled by looking at every frame: frame ranges, inclusive,
# in the video's frame numbers. A stance starts where the foot stops moving in the picture and
# ends where it leaves the ground.
LABELLED = {
    "fb1de004": {
        "clip": "a woman running across a fence line in side view, 480 x 352, 30 fps (Sports2D git history, "
                "commit 4573cde, Sports2D/Demo/demo3.mp4; no licence stated, so not in the project)",
        "frames": [0, 29],
        "right": [[0, 11], [23, 29]],
        "left": [[14, 20]],
    },
}


def scored(motion, track, estimator, truth: np.ndarray) -> dict:
    """The three flag sets of `motion` (reconstructed from `track`) against `truth` (T, 2)."""
    from services.contacts.estimator import CONTACT_THRESHOLD, planted
    from services.pose.subject import track_window
    from services.reconstruction.keypoints import observe
    from services.reconstruction.label_flips import undo_label_flips

    start, frames = int(motion.extras.get("video_start_frame", 0)), motion.num_frames
    window = track_window(track, start - int(track.start_frame), start - int(track.start_frame) + frames)
    observed = undo_label_flips(observe(window), np.asarray(motion.extras["label_flipped"], bool))
    probabilities = estimator.estimate(observed.keypoints2d, observed.confidence, window.fps)
    network = probabilities >= CONTACT_THRESHOLD
    with_planted = network | planted(observed, window.fps)
    final = np.asarray(motion.extras["contacts"], bool)
    truth = truth[:frames]

    def score(flags):
        return {"accuracy": [round(float(a), 3) for a in (flags == truth).mean(axis=0)],
                "mean": round(float((flags == truth).mean()), 3),
                "found": int((flags & truth).sum()), "false": int((flags & ~truth).sum()),
                "no_foot_frames": int((~flags.any(axis=1)).sum())}

    return {"frames": [start, start + frames - 1], "truth_down": int(truth.sum()),
            "no_foot_frames_truth": int((~truth.any(axis=1)).sum()),
            "network": score(network), "with_planted": score(with_planted), "final": score(final)}


def reconstructed(track, video: Path):
    from services.contacts.video_motion import video_motion
    from services.reconstruction import ReconstructionConfig

    return video_motion(track, ReconstructionConfig(), video.stem, "static", str(video), use_ray=False).motion


def trial_rows(tracks: Path | None, estimator, trials: list[str]) -> list[dict]:
    from services.pose import PoseTrack, estimate_video
    from tests.pose2sim_truth import marker_contacts

    rows = []
    for trial in trials:
        folder, trc = TRIALS[trial]
        for camera in ("cam01", "cam02", "cam03", "cam04"):
            video = SHARED / folder / f"{camera}.mp4"
            if not video.is_file():
                continue
            cached = None if tracks is None else tracks / f"{trial}_{camera}.npz"
            track = PoseTrack.load(cached) if cached is not None and cached.is_file() else estimate_video(video)
            motion = reconstructed(track, video)
            start = int(motion.extras.get("video_start_frame", 0))
            truth = marker_contacts(SHARED / folder / trc)[start:]
            rows.append({"video": f"{folder}/{camera}.mp4", **scored(motion, track, estimator, truth)})
            print(json.dumps(rows[-1]), flush=True)
    return rows


def labelled_row(video: Path, track_path: Path, estimator) -> dict:
    from services.pose import PoseTrack

    from services.pose.models import sha256_of

    labels = LABELLED.get(sha256_of(video.read_bytes())[:8])
    if labels is None:
        raise SystemExit(f"{video}: no labels for this file (known: {', '.join(LABELLED)})")
    track = PoseTrack.load(track_path)
    motion = reconstructed(track, video)
    start = int(motion.extras.get("video_start_frame", 0))
    last = labels["frames"][1]
    truth = np.zeros((last + 1, 2), bool)
    for foot, side in enumerate(("right", "left")):
        for first, end in labels[side]:
            truth[first:end + 1, foot] = True
    row = {"video": video.name, "clip": labels["clip"], **scored(motion, track, estimator, truth[start:])}
    print(json.dumps(row), flush=True)
    return row


def main(argv: list[str] | None = None) -> int:
    from services.contacts.estimator import FootContactEstimator

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracks", type=Path, default=None, help="folder of saved Pose2Sim tracks ({trial}_camNN.npz)")
    parser.add_argument("--clip", action="append", default=[], metavar="VIDEO=TRACK",
                        help="a labelled clip (LABELLED) and its pose track")
    parser.add_argument("--model", type=Path, default=None, help="contact network directory (default: the shipped one)")
    parser.add_argument("--trials", default=",".join(TRIALS), help=f"Pose2Sim trials to score (of {', '.join(TRIALS)}; "
                        "empty: only the --clip rows)")
    parser.add_argument("--out", type=Path, default=RESULT)
    args = parser.parse_args(argv)
    estimator = FootContactEstimator(args.model) if args.model else FootContactEstimator()
    trials = [name for name in args.trials.split(",") if name]
    unknown = [name for name in trials if name not in TRIALS]
    if unknown:
        raise SystemExit(f"--trials: {', '.join(unknown)} is not one of {', '.join(TRIALS)}")
    rows = trial_rows(args.tracks, estimator, trials)
    for clip in args.clip:
        video, _, track = clip.partition("=")
        rows.append(labelled_row(Path(video), Path(track), estimator))
    from learner.atomic_io import atomic_write_json
    atomic_write_json(args.out, {"model": str(args.model or "shipped"), "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
