"""Suite `pose`: the video front end.

* pose estimation: `services.pose.estimate_video` serially (no Ray, one interpreter thread
  per model) on a real video; frames per second of wall time, and frames per CPU-second
  of this process (all its threads), i.e. per core whatever else the machine is doing;
* reconstruction: seconds of `services.reconstruction` per second of video, on the pose
  track just estimated; skipped with a message until that package can be imported.
"""
from __future__ import annotations

import importlib
import time
from pathlib import Path

from learner.errors import SfvError
from services.bench.config import BenchConfig
from services.bench.measure import Summary, interleaved
from services.bench.result import SuiteResult

SHARED = Path(__file__).resolve().parents[2].parent / "shared"
DEFAULT_VIDEO = SHARED / "data" / "video" / "pose2sim_balancing" / "cam01.mp4"
SHARED_MODELS = SHARED / "models" / "blazepose"


def find_models(explicit: str | None) -> tuple[str | None, str]:
    """(models_dir for estimate_video, where it came from); raises SfvError when none is found."""
    from services.pose.models import resolve_model_files

    if explicit is not None:
        resolve_model_files(explicit)
        return explicit, explicit
    try:
        files = resolve_model_files(None)
        return None, str(files.detector.parent)
    except SfvError:
        if SHARED_MODELS.is_dir():
            resolve_model_files(SHARED_MODELS)
            return str(SHARED_MODELS), str(SHARED_MODELS)
        raise


def run_pose_suite(config: BenchConfig, log) -> SuiteResult:
    video = Path(config.pose_video) if config.pose_video else DEFAULT_VIDEO
    if not video.is_file():
        return SuiteResult.skip("pose", f"{video}: video not found (pass --pose-video)", video=str(video))
    try:
        from services.pose import estimate_video

        models_dir, models_from = find_models(config.pose_models)
    except (ImportError, SfvError) as exc:
        return SuiteResult.skip("pose", f"pose estimation unavailable: {exc}", video=str(video))
    tracks = []

    def pose_once() -> float:
        wall, cpu = time.perf_counter(), time.process_time()
        track = estimate_video(video, models_dir=models_dir, use_ray=False)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        tracks.append((track, wall, cpu))
        return len(track) / wall

    runs = interleaved({"pose_frames_per_s": pose_once}, config.repeats,
                       on_result=lambda r, n, v: log(f"  rep {r + 1}: {n} = {v:,.1f}"))
    measured = tracks[-config.repeats:]
    track = measured[-1][0]
    metrics = {
        "pose_frames_per_s": Summary(tuple(runs["pose_frames_per_s"]), "frames/s (wall, serial)"),
        "pose_frames_per_cpu_s": Summary(tuple(len(t) / cpu for t, _, cpu in measured), "frames per CPU-second"),
    }
    video_seconds = len(track) / track.fps
    settings = {"video": str(video), "frames": len(track), "fps": track.fps, "video_seconds": video_seconds,
                "models": models_from, "use_ray": False, "repeats": config.repeats}
    result = SuiteResult("pose", metrics, settings=settings)
    reconstruction = _reconstruction_runner()
    if isinstance(reconstruction, str):
        result.notes.append(f"reconstruction skipped: {reconstruction}")
        return result

    def reconstruct_once() -> float:
        start = time.perf_counter()
        reconstruction(track)
        return (time.perf_counter() - start) / video_seconds

    try:
        recon = interleaved({"reconstruction_s_per_video_s": reconstruct_once}, config.reconstruction_repeats, warmup=0,
                            on_result=lambda r, n, v: log(f"  rep {r + 1}: {n} = {v:,.2f}"))
    except SfvError as exc:
        result.notes.append(f"reconstruction failed on {video.name}'s pose track: {exc}")
        return result
    result.metrics["reconstruction_s_per_video_s"] = Summary(tuple(recon["reconstruction_s_per_video_s"]),
                                                             "s of reconstruction per s of video (lower is better)")
    result.settings["reconstruction"] = f"{reconstruction.__module__}.{reconstruction.__name__}, default config, no warm-up"
    result.settings["reconstruction_repeats"] = config.reconstruction_repeats
    return result


RECONSTRUCTION_ENTRY_POINTS = (("services.reconstruction", "reconstruct_track"),
                               ("services.reconstruction.reconstruct", "reconstruct_track"))


def _reconstruction_runner():
    """services.reconstruction's track -> motion function, or why there is none."""
    problems = []
    for module_name, attribute in RECONSTRUCTION_ENTRY_POINTS:
        try:
            function = getattr(importlib.import_module(module_name), attribute, None)
        except ImportError as exc:
            problems.append(f"{module_name} is not importable ({exc})")
            continue
        if callable(function):
            return function
        problems.append(f"{module_name} has no {attribute}(track)")
    return "; ".join(problems)
