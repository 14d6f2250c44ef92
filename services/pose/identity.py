"""Global identities from per-chunk local tracks.

1. Across chunks: a chunk's local track continues the previous chunk's identity when the
   two agree on the warm-up frames both decoded (mean 2D keypoint distance on the last
   shared frame below `stitch_limit` x ROI side); pairs are taken closest first and one to
   one, so two local tracks never share an identity in the same frame. Unmatched local
   tracks get new identities.
2. Across gaps: an identity that ends (lost: occluded, left, a blank frame) is continued by
   one that starts at most `relink_gap_s` later close to where it ended (mean keypoint
   distance below `relink_limit` x ROI side), closest first, one to one. Two identities
   seen in the same frame are never joined, so this cannot merge two people who are on
   screen together.
Identities are then renumbered 0, 1, ... by first appearance (ties: left to right).
"""
from __future__ import annotations

import numpy as np

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


def relink_gaps(rows: PeopleRows, fps: float, config: PoseConfig) -> PeopleRows:
    """Join identities across short gaps (see the module docstring)."""
    max_gap = max(1, int(round(config.relink_gap_s * fps)))
    ids = [int(p) for p in np.unique(rows.person)]
    first = {p: int(rows.frame[rows.person == p].min()) for p in ids}
    last = {p: int(rows.frame[rows.person == p].max()) for p in ids}
    frames = {p: set(rows.frame[rows.person == p].tolist()) for p in ids}
    row_at = {(int(rows.person[i]), int(rows.frame[i])): i for i in range(len(rows))}
    costs: dict[tuple[int, int], float] = {}
    for ended in ids:
        for started in ids:
            if 0 < first[started] - last[ended] <= max_gap:
                costs[(ended, started)] = _distance(rows, row_at[(ended, last[ended])], rows, row_at[(started, first[started])])
    parent = {p: p for p in ids}
    for started, ended in sorted(_closest_pairs(costs, config.relink_limit).items(), key=lambda kv: first[kv[0]]):
        root = _root(parent, ended)
        members = [p for p in ids if _root(parent, p) == root]
        if any(frames[started] & frames[m] for m in members):
            continue  # seen together with that identity at some frame: two people
        parent[started] = root
    person = np.array([_root(parent, int(p)) for p in rows.person], np.int32)
    return _renumbered(rows.with_person(person))


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
