"""Issue 48 part 5: a person hidden for a second keeps one identity.

On each Pose2Sim two-people camera where both people are tracked (cam01, cam02, cam04), one
person at a time is painted over (their keypoint box plus 40 px, per frame, in a flat green) for
frames 20-79 (1.0 s at 60 fps); the painted video is written with OpenCV and run through
`estimate_people` twice:

- before: gaps joined on position alone across at most 0.5 s, no cut on a change of clothes
  (`relink_max_gap_s=0.5`, `switch_limit` off): the rules before appearance;
- now: the defaults (clothes' colours and last hip speed across up to 3 s).

A row counts as kept when one identity covers the hidden person's frames before (< 20) and after
(> 80) the occluder. Also written: each trial's identities without occluder, and cam03's (the
camera where one track slid from the man onto the woman).

    .venv/bin/python -m bench.scripts.identity_occlusion --out bench/results/identity_occlusion.json
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from learner.atomic_io import atomic_write_json  # noqa: E402
from services.pose.config import PoseConfig  # noqa: E402
from services.pose.pipeline import estimate_people  # noqa: E402

TRIAL = REPO.parent / "shared" / "data" / "video" / "pose2sim_two_people"
HIDDEN = range(20, 80)
BEFORE = PoseConfig(relink_max_gap_s=0.5, switch_limit=10.0)


def spans(rows) -> list[list[int]]:
    return sorted([int(rows.frame[rows.person == p].min()), int(rows.frame[rows.person == p].max()),
                   int((rows.person == p).sum())] for p in np.unique(rows.person))


def paint_over(source: Path, rows, person: int, out: Path) -> None:
    capture = cv2.VideoCapture(str(source))
    size = (int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)), int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)))
    writer = cv2.VideoWriter(str(out), cv2.VideoWriter_fourcc(*"mp4v"), capture.get(cv2.CAP_PROP_FPS), size)
    index = 0
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        mine = rows.keypoints2d[(rows.person == person) & (rows.frame == index)]
        if index in HIDDEN and len(mine):
            (x0, y0), (x1, y1) = mine[0].min(axis=0) - 40, mine[0].max(axis=0) + 40
            cv2.rectangle(frame, (int(x0), int(y0)), (int(x1), int(y1)), (90, 110, 60), -1)
        writer.write(frame)
        index += 1
    writer.release()


def kept(rows) -> bool:
    """One identity seen both before and after the occluder, besides one seen throughout (the other person)."""
    return sum(1 for p in np.unique(rows.person)
               if rows.frame[rows.person == p].min() < HIDDEN.start and rows.frame[rows.person == p].max() > HIDDEN.stop) >= 2


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    if not TRIAL.is_dir():
        print(f"{TRIAL}: absent (../shared)", file=sys.stderr)
        return 2
    document = {"hidden_frames": [HIDDEN.start, HIDDEN.stop - 1], "fps": 60.0, "unoccluded": {}, "rows": []}
    for cam in ("cam01", "cam02", "cam03", "cam04"):
        video = TRIAL / f"{cam}.mp4"
        document["unoccluded"][cam] = {"before": spans(estimate_people(video, config=BEFORE).rows),
                                       "now": spans(estimate_people(video).rows)}
        print(cam, document["unoccluded"][cam], flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for cam in ("cam01", "cam02", "cam04"):
            rows = estimate_people(TRIAL / f"{cam}.mp4").rows
            for person in np.unique(rows.person):
                painted = Path(tmp) / f"{cam}_{person}.mp4"
                paint_over(TRIAL / f"{cam}.mp4", rows, int(person), painted)
                before, now = estimate_people(painted, config=BEFORE).rows, estimate_people(painted).rows
                row = {"camera": cam, "hidden_person": int(person), "before": spans(before), "now": spans(now),
                       "kept_before": kept(before), "kept_now": kept(now)}
                document["rows"].append(row)
                print(row, flush=True)
    document["kept"] = {"before": sum(r["kept_before"] for r in document["rows"]),
                        "now": sum(r["kept_now"] for r in document["rows"]), "of": len(document["rows"])}
    atomic_write_json(args.out, document)
    print(document["kept"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
