"""Finding an expert in an experts directory (`sfv experts --out DIR`): `DIR/<clip>/` is a
run directory; `<clip>_mirror` is served by symmetry from `DIR/<clip>/`."""
from __future__ import annotations

from pathlib import Path

from actors.character.mirror import MIRROR_SUFFIX
from learner.errors import SfvError
from services.experts.expert import Expert
from services.experts.mirrored_expert import MirroredExpert


def load_expert(experts_dir: str | Path, clip: str, max_batch: int = 64) -> Expert:
    """The expert for `clip` in an experts directory: `DIR/<clip>/` (a run directory), or for
    `<clip>_mirror` the mirrored expert of `DIR/<clip>/`."""
    experts_dir = Path(experts_dir)
    if clip.endswith(MIRROR_SUFFIX):
        original = clip[: -len(MIRROR_SUFFIX)]
        if not (experts_dir / original).is_dir():
            raise SfvError(f"{experts_dir / original}: no expert for {original}, which {clip} mirrors")
        return MirroredExpert(Expert.from_run(experts_dir / original, max_batch))
    if not (experts_dir / clip).is_dir():
        raise SfvError(f"{experts_dir / clip}: no expert for clip {clip}")
    return Expert.from_run(experts_dir / clip, max_batch)
