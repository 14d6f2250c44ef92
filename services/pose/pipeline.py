"""Video file -> everyone in it (PeopleTrack) -> the subject's PoseTrack: split into frame
chunks, estimate each (serially or as Ray tasks, same code), join identities in order,
choose the subject, fill the frames where the subject is not seen."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from learner.errors import SfvError
from services.pose.config import PoseConfig
from services.pose.identity import link_chunks, relink_gaps, split_switches
from services.pose.models import resolve_model_files
from services.pose.people import PeopleEstimator
from services.pose.people_chunk import estimate_people_chunk
from services.pose.subject import PeopleTrack, PersonChoice, choose_subject, subject_reason, subject_track
from services.pose.track import PoseTrack
from services.pose.video import VideoInfo, probe_video


def chunk_ranges(frame_count: int, chunk_frames: int) -> list[tuple[int, int]]:
    """[(start, stop), ...] covering 0..frame_count in chunks of at most chunk_frames."""
    if chunk_frames < 1:
        raise SfvError(f"chunk_frames must be >= 1, got {chunk_frames}")
    return [(start, min(start + chunk_frames, frame_count)) for start in range(0, frame_count, chunk_frames)]


def estimate_people(path: str | Path, models_dir: str | Path | None = None, use_ray: bool = False,
                    chunk_frames: int | None = None, config: PoseConfig | None = None,
                    landmark_model: str | Path | None = None, frames: tuple[int, int | None] | None = None) -> PeopleTrack:
    """Everyone in video frames `frames` = (A, B) (B exclusive, None: to the end; default all),
    identities kept across frames, chunks and short gaps (`people.py`, `identity.py`).

    models_dir: where pose_detection.tflite and the landmark model live (default
    $SFV_POSE_MODELS or the user cache filled by `sfv models fetch`); landmark_model: an
    explicit .tflite/.onnx landmark file. use_ray: run chunks as Ray tasks (starts a
    local Ray when none is running); chunk_frames: frames per chunk (config.chunk_frames).
    """
    config = config or PoseConfig()
    path = Path(path)
    info = probe_video(path)
    first, stop = _frame_range(info, frames)
    files = resolve_model_files(models_dir, landmark_model)
    PeopleEstimator(files, config)  # load both models here so a bad file fails before any task starts
    ranges = [(first + a, first + b) for a, b in chunk_ranges(stop - first, chunk_frames or config.chunk_frames)]
    if use_ray:
        from services.pose.distributed import run_chunks_on_ray

        chunks = run_chunks_on_ray(path, ranges, files, config, estimate_people_chunk)
    else:
        chunks = [estimate_people_chunk(path, start, end, files, config) for start, end in ranges]
    kept = []
    for (start, end), chunk in zip(ranges, chunks, strict=True):
        kept.append(chunk)
        if chunk.decoded < end - start:  # containers can over-report their frame count
            break
    decoded = sum(c.decoded for c in kept)
    if decoded == 0:
        raise SfvError(f"{info.path}: video has no decodable frames" + (f" in --frames {first}:{stop}" if first else ""))
    rows = relink_gaps(split_switches(link_chunks(kept, config), config), info.fps, config)
    return PeopleTrack(fps=info.fps, image_size=(info.width, info.height), start_frame=first,
                       frame_count=decoded, rows=rows,
                       camera_homography=np.concatenate([c.camera_homography for c in kept]),
                       camera_inliers=np.concatenate([c.camera_inliers for c in kept]))


def _frame_range(info: VideoInfo, frames: tuple[int, int | None] | None) -> tuple[int, int]:
    first, stop = frames if frames is not None else (0, None)
    stop = info.frame_count if stop is None else min(stop, info.frame_count)
    if first >= info.frame_count:
        raise SfvError(f"--frames {first}:{'' if frames[1] is None else frames[1]}: {info.path} has only "
                       f"{info.frame_count} frames")
    return first, stop


def estimate_video(path: str | Path, models_dir: str | Path | None = None, use_ray: bool = False,
                   chunk_frames: int | None = None, config: PoseConfig | None = None,
                   landmark_model: str | Path | None = None, choice: PersonChoice | None = None,
                   frames: tuple[int, int | None] | None = None, say=None) -> PoseTrack:
    """The subject's per-frame BlazePose track (`estimate_people`, then `subject.py`'s choice:
    by default the person seen throughout who moves most); `say` (e.g. print) gets the one
    line naming the subject and why."""
    people = estimate_people(path, models_dir, use_ray, chunk_frames, config, landmark_model, frames)
    choice = choice or PersonChoice()
    person = choose_subject(people, choice, str(path))
    if say is not None:
        say(subject_reason(people, person, choice))
    return subject_track(people, person)
