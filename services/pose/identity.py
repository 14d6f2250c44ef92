"""Global identities from per-chunk local tracks.

1. Across chunks: a chunk's local track continues the previous chunk's identity when the
   two agree on the warm-up frames both decoded (mean 2D keypoint distance on the last
   shared frame below `stitch_limit` x ROI side); pairs are taken closest first and one to
   one, so two local tracks never share an identity in the same frame. Unmatched local
   tracks get new identities.
2. Switches: a track whose clothes (`appearance.py`) stop matching its first answers has slid
   onto someone else (Pose2Sim two-people cam03: the man's track slides onto the woman
   behind him at frame 61, its appearance distance jumping from .42 to .79-.90, while one
   person's answers stay within .51 of its first ones); it is cut there.
3. Across gaps: an identity that ends (lost: occluded, left, a blank frame) is continued by
   one that starts later, closest first, one to one:
   - at most `relink_gap_s` later: where it would be at its last hip speed (mean keypoint
     distance below `relink_limit` x ROI side) and, where both are known, in the same clothes;
   - up to `relink_max_gap_s` later (someone behind a tree for two seconds): in the same
     clothes (Hellinger distance below `appearance_limit`), within a position tolerance that
     grows by `relink_spread_per_s` ROI sides a second.
   Two identities seen in the same frame are never joined, so this cannot merge two people
   who are on screen together.
Identities are then renumbered 0, 1, ... by first appearance (ties: left to right).
"""
from __future__ import annotations

import numpy as np

from services.pose.appearance import appearance_distance, mean_signature
from services.pose.config import PoseConfig
from services.pose.people_chunk import PeopleChunk, PeopleRows


def _frame_rows(rows: PeopleRows, frame: int) -> dict[int, int]:
    """person -> row index in `frame`."""
    return {int(rows.person[i]): int(i) for i in np.flatnonzero(rows.frame == frame)}


def _distance(a: PeopleRows, i: int, b: PeopleRows, j: int) -> float:
    """Mean keypoint distance of two rows as a fraction of their larger ROI side."""
    mean = float(np.linalg.norm(a.keypoints2d[i] - b.keypoints2d[j], axis=1).mean())
    return mean / max(float(a.roi_size[i]), float(b.roi_size[j]), 1.0)


def _closest_pairs(costs: dict[tuple[int, int], float], limit: float) -> dict[int, int]:
    """Greedy one-to-one assignment (closest first) of pairs under `limit`: {right: left}."""
    matched: dict[int, int] = {}
    used: set[int] = set()
    for (left, right), cost in sorted(costs.items(), key=lambda item: item[1]):
        if cost < limit and left not in used and right not in matched:
            matched[right] = left
            used.add(left)
    return matched


def _link_chunk(previous: PeopleRows, chunk: PeopleChunk, next_id: int, limit: float) -> tuple[PeopleRows, int]:
    """The chunk's own frames with global ids, continuing `previous` (already global) on the warm-up."""
    rows = chunk.rows
    costs: dict[tuple[int, int], float] = {}
    for frame in range(chunk.first, chunk.start):  # later frames overwrite: the most settled answer counts
        before, here = _frame_rows(previous, frame), _frame_rows(rows, frame)
        for identity, i in before.items():
            for local, j in here.items():
                costs[(identity, local)] = _distance(previous, i, rows, j)
    mapping = _closest_pairs(costs, limit)
    for local in np.unique(rows.person):
        if int(local) not in mapping:
            mapping[int(local)] = next_id
            next_id += 1
    own = rows.select((rows.frame >= chunk.start) & (rows.frame < chunk.start + chunk.decoded))
    return own.with_person(np.array([mapping[int(p)] for p in own.person], np.int32)), next_id


def link_chunks(chunks: list[PeopleChunk], config: PoseConfig) -> PeopleRows:
    """Chunks in frame order -> one table with identities continued across chunk boundaries."""
    linked: list[PeopleRows] = []
    previous: PeopleRows | None = None
    next_id = 0
    for chunk in chunks:
        if previous is None:
            mapping_rows = chunk.rows.select((chunk.rows.frame >= chunk.start) & (chunk.rows.frame < chunk.start + chunk.decoded))
            ids = np.unique(mapping_rows.person)
            remap = {int(p): n for n, p in enumerate(ids)}
            part = mapping_rows.with_person(np.array([remap[int(p)] for p in mapping_rows.person], np.int32))
            next_id = len(ids)
        else:
            part, next_id = _link_chunk(previous, chunk, next_id, config.stitch_limit)
        linked.append(part)
        previous = part
    return PeopleRows.concatenate(linked)


def split_switches(rows: PeopleRows, config: PoseConfig) -> PeopleRows:
    """Cut each identity where its clothes stop matching its first answers (`switch_rows`
    answers in a row past `switch_limit`): the track has slid onto someone else. The part
    after the cut is a new identity, for `relink_gaps` to join to whoever it matches."""
    person = rows.person.copy()
    next_id = int(person.max()) + 1 if len(person) else 0
    for identity in np.unique(rows.person):
        mine = np.flatnonzero(rows.person == identity)
        mine = mine[np.argsort(rows.frame[mine], kind="stable")]
        begin = 0
        while begin < len(mine):
            cut = _first_switch(rows.appearance[mine[begin:]], config)
            if cut is None:
                break
            begin += cut
            person[mine[begin:]] = next_id
            next_id += 1
    return rows.with_person(person)


REFERENCE_ROWS = 15  # a track's clothes: the mean of its first 15 answers (a quarter second at 60 fps)


def _first_switch(signatures: np.ndarray, config: PoseConfig) -> int | None:
    reference = mean_signature(signatures[:REFERENCE_ROWS])
    far = np.array([(appearance_distance(reference, s) or 0.0) > config.switch_limit for s in signatures])
    run = np.convolve(far, np.ones(config.switch_rows), "valid") >= config.switch_rows
    hits = np.flatnonzero(run)
    return int(hits[0]) if len(hits) and hits[0] > 0 else None


def relink_gaps(rows: PeopleRows, fps: float, config: PoseConfig) -> PeopleRows:
    """Join identities across gaps (see the module docstring)."""
    short = max(1, int(round(config.relink_gap_s * fps)))
    longest = max(short, int(round(config.relink_max_gap_s * fps)))
    ids = [int(p) for p in np.unique(rows.person)]
    first = {p: int(rows.frame[rows.person == p].min()) for p in ids}
    last = {p: int(rows.frame[rows.person == p].max()) for p in ids}
    frames = {p: set(rows.frame[rows.person == p].tolist()) for p in ids}
    row_at = {(int(rows.person[i]), int(rows.frame[i])): i for i in range(len(rows))}
    clothes = _clothes(rows, ids)
    costs: dict[tuple[int, int], float] = {}
    for ended in ids:
        for started in ids:
            gap = first[started] - last[ended]
            if not 0 < gap <= longest:
                continue
            looks = appearance_distance(clothes[ended], clothes[started])
            if (looks is not None and looks > config.appearance_limit) or (looks is None and gap > short):
                continue  # other clothes; or a long gap with nothing to tell two people apart
            tolerance = config.relink_limit + config.relink_spread_per_s * max(0, gap - short) / fps
            moved = _predicted_distance(rows, ended, last[ended], row_at, row_at[(started, first[started])], gap)
            if moved < tolerance:
                costs[(ended, started)] = moved / tolerance + (looks or 0.0) / config.appearance_limit
    parent = {p: p for p in ids}
    for started, ended in sorted(_closest_pairs(costs, np.inf).items(), key=lambda kv: first[kv[0]]):
        root = _root(parent, ended)
        members = [p for p in ids if _root(parent, p) == root]
        if any(frames[started] & frames[m] for m in members):
            continue  # seen together with that identity at some frame: two people
        parent[started] = root
    person = np.array([_root(parent, int(p)) for p in rows.person], np.int32)
    return _renumbered(rows.with_person(person))


VELOCITY_FRAMES = 10  # an identity's last speed: its hips over its last 10 frames


def _predicted_distance(rows: PeopleRows, ended: int, last: int, row_at: dict, j: int, gap: int) -> float:
    """Mean keypoint distance (fraction of the ROI side) between where `ended` would be after
    `gap` frames at its last hip speed and the answer `j`."""
    i = row_at[(ended, last)]
    earlier = [row_at[(ended, f)] for f in range(last - VELOCITY_FRAMES, last) if (ended, f) in row_at]
    velocity = np.zeros(2)
    if earlier:
        k = earlier[0]
        hips = rows.keypoints2d[[i, k]][:, 23:25].mean(axis=1)
        velocity = (hips[0] - hips[1]) / max(int(rows.frame[i] - rows.frame[k]), 1)
    predicted = rows.keypoints2d[i] + velocity * gap
    mean = float(np.linalg.norm(predicted - rows.keypoints2d[j], axis=1).mean())
    return mean / max(float(rows.roi_size[i]), float(rows.roi_size[j]), 1.0)


CLEAR_OVERLAP = 0.2  # an answer whose keypoint box is covered more than this by another's is not a clean look


def _clothes(rows: PeopleRows, ids: list[int]) -> dict[int, np.ndarray]:
    """Each identity's mean signature over its answers that nobody else covered (all its
    answers where every one was covered)."""
    boxes = np.concatenate([rows.keypoints2d.min(axis=1), rows.keypoints2d.max(axis=1)], axis=1)
    clear = np.ones(len(rows), bool)
    for frame in np.unique(rows.frame):
        here = np.flatnonzero(rows.frame == frame)
        for a in here:
            area = max(float(np.prod(boxes[a, 2:] - boxes[a, :2])), 1.0)
            for b in here:
                if a != b:
                    inter = np.clip(np.minimum(boxes[a, 2:], boxes[b, 2:]) - np.maximum(boxes[a, :2], boxes[b, :2]), 0, None)
                    clear[a] &= float(inter.prod()) / area <= CLEAR_OVERLAP
    result = {}
    for p in ids:
        mine = rows.person == p
        result[p] = mean_signature(rows.appearance[mine & clear] if (mine & clear).any() else rows.appearance[mine])
    return result


def _root(parent: dict[int, int], p: int) -> int:
    while parent[p] != p:
        p = parent[p]
    return p


def _renumbered(rows: PeopleRows) -> PeopleRows:
    """Identities 0, 1, ... by first frame seen, ties by the hips' x in that frame."""
    def order(p: int):
        mine = np.flatnonzero(rows.person == p)
        head = mine[np.argmin(rows.frame[mine])]
        return int(rows.frame[head]), float(rows.keypoints2d[head, 23:25, 0].mean())

    ids = sorted((int(p) for p in np.unique(rows.person)), key=order)
    remap = {p: n for n, p in enumerate(ids)}
    result = rows.with_person(np.array([remap[int(p)] for p in rows.person], np.int32))
    order_rows = np.lexsort((result.person, result.frame))
    return result.select(order_rows)
