"""Retargeting onto the Unitree G1 (issue 25): before / after figures per clip.

For each clip, `sfv motion convert CLIP --character g1` (the command itself, in process) and
its report: key-body position error against the scaled source, limit clipping, penetration
and foot skating of the source (the humanoid), the scaled source and the robot, and the
seconds it took. The BVH clip is DeepMimic's jump written through a foreign skeleton (Mixamo
joint names, A-pose rest, Y up, centimetres, 1.1x the humanoid: `tests/foreign_rig.py`), so it
goes through the BVH importer first. Needs the cached model (`sfv models fetch --robot g1`).

    python bench/scripts/g1_retarget.py --out bench/results/g1_retarget.json [--clips walk,run,cartwheel,bvh:jump]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from actors.motion.formats.io import load_motion  # noqa: E402
from services.training.run_dir import write_json_atomic  # noqa: E402

KEEP = ("frames", "fps", "scale", "contact_frames", "key_body_error_m", "limit_clipping", "joint_speed",
        "penetration_m", "skating_m_s", "skating_on_source_contacts_m_s", "targets", "seconds", "cpu_seconds")


def source_for(clip: str, folder: Path) -> str:
    if not clip.startswith("bvh:"):
        return f"deepmimic:{clip}"
    from tests.foreign_rig import MIXAMO_NAMES, foreign_bvh_text

    name = clip.split(":", 1)[1]
    path = folder / f"{name}_mixamo.bvh"
    path.write_text(foreign_bvh_text(load_motion(f"deepmimic:{name}"), MIXAMO_NAMES, "y_up"))
    return str(path)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--clips", default="walk,run,cartwheel,bvh:jump")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    results = {}
    with tempfile.TemporaryDirectory(prefix="sfv-g1-bench-") as tmp:
        folder = Path(tmp)
        for clip in args.clips.split(","):
            source = source_for(clip, folder)
            out = folder / f"{clip.replace(':', '_')}_g1.npz"
            # The command as a user runs it (a subprocess: the benchmark package does not import the CLI).
            done = subprocess.run([sys.executable, "-m", "services.cli", "motion", "convert", source, "--character", "g1",
                                   "--out", str(out)], capture_output=True, text=True, cwd=REPO)
            if done.returncode:
                raise SystemExit(f"{clip}: sfv motion convert exited {done.returncode}: {done.stderr.strip()[-300:]}")
            report = json.loads(out.with_suffix(".json").read_text())["retarget"]
            results[clip] = {"source": "mixamo-rig BVH of deepmimic:" + clip.split(":")[1] if clip.startswith("bvh:") else source,
                             **{k: report[k] for k in KEEP}, "result_lines": done.stdout.splitlines()}
            print(clip, json.dumps(results[clip]["targets"]), f"{results[clip]['seconds']} s", flush=True)
    summary = {
        "what": "sfv motion convert CLIP --character g1: the scaled source's key bodies (pelvis, torso, knees, feet, "
                "shoulders, elbows, hands) against the G1's after per-frame IK; penetration (m, worst frame) and "
                "foot skating (m/s of an ankle while on the ground: each track's own foot_contact.py rule, and over the frames "
                "the source has that foot down) of the source humanoid, "
                "the scaled source (the G1's foot geoms on its target foot frames) and the robot",
        "targets": "key-body error (mean over bodies and frames) <= 5 cm after scaling, zero penetration, "
                   "robot skating no worse than the scaled source's",
        "machine": f"{platform.machine()}, {os.cpu_count()} cores shared with two trainings: `seconds` is wall time "
                   "at nice 19 under that load, `cpu_seconds` the CPU time the conversion used",
        "clips": results,
    }
    write_json_atomic(Path(args.out), summary)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
