"""Does giving a walker's unsupported frames their likelier foot agree with the markers? Issue 44.

    python bench/scripts/contact_support.py [--tracks DIR] [--out bench/results/contact_support.json]

For each camera of ../shared's Pose2Sim balancing trial, its pose track (DIR/balancing_camNN.npz,
`sfv pose VIDEO --out ... --serial`; estimated here when absent) is reconstructed as `sfv pipeline`
does it, which records the contact network's probabilities and the flags the reconstruction used
(`services/contacts/support.py` applied). The flags are scored per foot against the markers'
contacts (`tests/pose2sim_truth.marker_contacts`) on the motion's frames, with and without the
missed support filled (the network's flags: probability >= 0.5), and the frames with no foot down
are counted (the markers have none: she always stands on a foot).
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

RESULT = REPO / "bench" / "results" / "contact_support.json"
TRIAL = REPO.parent / "shared" / "data" / "video" / "pose2sim_balancing"


def camera_row(video: Path, tracks: Path | None) -> dict:
    from services.contacts.estimator import CONTACT_THRESHOLD
    from services.contacts.video_motion import video_motion
    from services.pose import PoseTrack, estimate_video
    from services.reconstruction import ReconstructionConfig
    from tests.pose2sim_truth import marker_contacts

    cached = None if tracks is None else tracks / f"balancing_{video.stem}.npz"
    track = PoseTrack.load(cached) if cached is not None and cached.is_file() else estimate_video(video)
    motion = video_motion(track, ReconstructionConfig(), video.stem, "static", str(video), use_ray=False).motion
    start, frames = int(motion.extras.get("video_start_frame", 0)), motion.num_frames
    truth = marker_contacts()[start:start + frames]
    filled = np.asarray(motion.extras["contacts"], bool)
    network = np.asarray(motion.extras["contact_probability"]) >= CONTACT_THRESHOLD
    score = lambda flags: [round(float(a), 3) for a in (flags == truth).mean(axis=0)]
    return {"video": video.name, "frames": [start, start + frames - 1],
            "accuracy_network": score(network), "accuracy_filled": score(filled),
            "mean_network": round(float((network == truth).mean()), 3), "mean_filled": round(float((filled == truth).mean()), 3),
            "no_foot_frames_network": int((~network.any(axis=1)).sum()), "no_foot_frames_filled": int((~filled.any(axis=1)).sum()),
            "no_foot_frames_markers": int((~truth.any(axis=1)).sum())}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracks", type=Path, default=None, help="folder of saved tracks (balancing_camNN.npz); "
                        "absent: BlazePose runs on each video")
    parser.add_argument("--out", type=Path, default=RESULT)
    args = parser.parse_args(argv)
    rows = []
    for camera in ("cam01", "cam02", "cam03", "cam04"):
        rows.append(camera_row(TRIAL / f"{camera}.mp4", args.tracks))
        print(json.dumps(rows[-1]), flush=True)
    from learner.atomic_io import atomic_write_json
    atomic_write_json(args.out, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
