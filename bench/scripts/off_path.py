"""How far does a reconstruction's root leave its own path? The threshold of the reference check's
off-path rule (`services/reconstruction/plausibility.py` `OFF_PATH_M`), measured on real videos.

    python bench/scripts/off_path.py TRACK.npz=VIDEO [...] [--out bench/results/off_path.json]

Each TRACK.npz is a pose track of its subject (`sfv pose VIDEO --out TRACK.npz --serial`, or the
`track.npz` a pipeline run saved). It is reconstructed as `sfv pipeline` does it (static camera,
learned contacts; `services/contacts/video_motion.py`), and before the check repairs anything the
root's horizontal distance from the robust local path of the frames around it is measured
(`path_residuals`): the largest, the 99th percentile, the frames over the threshold, and the
check's one line on that reconstruction with the rule and without it (the spike rules alone),
and the line of the pipeline's final check (after it cuts unsettled ends, where it does).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

RESULT = REPO / "bench" / "results" / "off_path.json"


def measure(track_file: Path, video: Path) -> dict:
    from services.contacts.video_motion import video_motion
    from services.pose import PoseTrack
    from services.reconstruction import ReconstructionConfig
    from services.reconstruction import plausibility

    track = PoseTrack.load(track_file)
    started = time.time()
    captured = {}
    original = plausibility.check_reference

    def spy(motion, contacts=None):  # the reconstruction as the check receives it, before any repair
        captured.setdefault("before", motion)
        return original(motion, contacts)

    plausibility.check_reference = spy
    try:
        made = video_motion(track, ReconstructionConfig(), video.stem, "static", str(video), use_ray=False)
    finally:
        plausibility.check_reference = original
    before = captured["before"]
    fps = float(before.fps)
    residual = plausibility.path_residuals(before.root_pos, fps)
    speeds = plausibility.root_speeds(before.root_pos, fps)
    _, with_rule = original(before, before.extras.get("contacts"))
    saved = plausibility.OFF_PATH_M
    plausibility.OFF_PATH_M = np.inf
    try:
        _, spikes_only = original(before, before.extras.get("contacts"))
    finally:
        plausibility.OFF_PATH_M = saved
    after = plausibility.root_speeds(made.motion.root_pos, fps)
    return {"video": str(video), "frames": int(len(before.root_pos)), "fps": fps,
            "residual_max_m": round(float(residual.max()), 3), "residual_p99_m": round(float(np.percentile(residual, 99)), 3),
            "residual_median_m": round(float(np.median(residual)), 4),
            "frames_over_threshold": np.flatnonzero(residual > plausibility.OFF_PATH_M).tolist(),
            "speed_max_before_m_s": round(float(speeds.max()), 2), "speed_max_after_m_s": round(float(after.max()), 2),
            "check_line": with_rule.line, "check_line_spike_rules_only": spikes_only.line,
            "pipeline_check_line": made.check,  # after the ends' cut, where there is one
            "seconds": round(time.time() - started, 1)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pairs", nargs="+", help="TRACK.npz=VIDEO")
    parser.add_argument("--out", type=Path, default=RESULT)
    args = parser.parse_args(argv)
    from services.reconstruction.plausibility import OFF_PATH_M
    rows = []
    for pair in args.pairs:
        track, _, video = pair.partition("=")
        row = measure(Path(track), Path(video))
        rows.append(row)
        print(json.dumps({k: v for k, v in row.items() if not k.startswith("check_line")}), flush=True)
    result = {"threshold_m": OFF_PATH_M, "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    from learner.atomic_io import atomic_write_json
    atomic_write_json(args.out, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
