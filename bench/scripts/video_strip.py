"""A frame strip from an MP4, for the docs: the frames at the given seconds side by side, each labelled.

    python -m bench.scripts.video_strip VIDEO.mp4 --seconds 0.5 2 4 6 8 --out docs/strip.png [--height 240]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def frame_strip(video: Path, seconds: list[float], height: int) -> "np.ndarray":  # noqa: F821
    import cv2
    import numpy as np

    capture = cv2.VideoCapture(str(video))
    if not capture.isOpened():
        raise SystemExit(f"video_strip: {video}: cannot open the video")
    fps = capture.get(cv2.CAP_PROP_FPS) or 30.0
    frames = []
    for t in seconds:
        capture.set(cv2.CAP_PROP_POS_FRAMES, int(round(t * fps)))
        ok, frame = capture.read()
        if not ok:
            raise SystemExit(f"video_strip: {video}: no frame at {t} s")
        frame = cv2.resize(frame, (int(frame.shape[1] * height / frame.shape[0]), height), interpolation=cv2.INTER_AREA)
        cv2.putText(frame, f"{t:g} s", (8, height - 10), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2, cv2.LINE_AA)
        frames.append(frame)
    capture.release()
    return np.concatenate(frames, axis=1)


def main(argv=None) -> int:
    import cv2

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("video", type=Path)
    p.add_argument("--seconds", type=float, nargs="+", required=True)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--height", type=int, default=240)
    args = p.parse_args(argv)
    strip = frame_strip(args.video, args.seconds, args.height)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), strip)
    print(f"{args.out}: {len(args.seconds)} frames of {args.video}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
