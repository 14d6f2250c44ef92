"""Finding an expert in an experts directory (`sfv experts --out DIR`): `DIR/<clip>/` is a
run directory; `<clip>_mirror` is served by symmetry from `DIR/<clip>/`.

The character (`EnvConfig.character`, `--character`) is part of what an experts directory is:
every run in it trains the same body, which its config.json remembers (`run_character`,
`directory_character`). Mirrored experts are any body's that declares its hinge mirror signs
(humanoid3d and the G1, `check_mirror`); the motor module that distils experts is the
humanoid3d's only for now (`sfv distill`, `sfv one-shot`: its dataset has the humanoid's sizes,
`services/motor/dataset.py`; `humanoid_experts_only`)."""
from __future__ import annotations

from pathlib import Path

from actors.character.mirror import MIRROR_SUFFIX
from learner.errors import SfvError
from services.experts.expert import Expert
from services.experts.mirrored_expert import MIRROR_CHARACTERS, MirroredExpert, check_mirror

__all__ = ["MIRROR_CHARACTERS", "check_mirror", "directory_character", "humanoid_experts_only", "load_expert", "run_character"]


def load_expert(experts_dir: str | Path, clip: str, max_batch: int = 64) -> Expert:
    """The expert for `clip` in an experts directory: `DIR/<clip>/` (a run directory), or for
    `<clip>_mirror` the mirrored expert of `DIR/<clip>/` (on that run's body)."""
    experts_dir = Path(experts_dir)
    if clip.endswith(MIRROR_SUFFIX):
        original = clip[: -len(MIRROR_SUFFIX)]
        if not (experts_dir / original).is_dir():
            raise SfvError(f"{experts_dir / original}: no expert for {original}, which {clip} mirrors")
        check_mirror(clip, run_character(experts_dir / original))
        return MirroredExpert(Expert.from_run(experts_dir / original, max_batch))
    if not (experts_dir / clip).is_dir():
        raise SfvError(f"{experts_dir / clip}: no expert for clip {clip}")
    return Expert.from_run(experts_dir / clip, max_batch)


def run_character(run_dir: str | Path) -> str:
    """The body a run trains (its config.json's `env.character`; runs written before the G1 read as humanoid3d)."""
    from services.training.run_dir import read_run_config

    return read_run_config(run_dir).env.character


def directory_character(experts_dir: str | Path) -> tuple[str, Path] | None:
    """(character, run directory) of the first trained expert (a run directory with a
    checkpoint) in the experts directory, in name order; None when it has none yet."""
    from services.training.run_dir import CONFIG_FILE, checkpoint_files

    experts_dir = Path(experts_dir)
    if not experts_dir.is_dir():
        return None
    for run_dir in sorted(p for p in experts_dir.iterdir() if p.is_dir()):
        if (run_dir / CONFIG_FILE).is_file() and checkpoint_files(run_dir):
            return run_character(run_dir), run_dir
    return None


def humanoid_experts_only(experts_dir: str | Path, clips: list[str]) -> None:
    """Refuse (one line) any clip whose expert is not the humanoid3d's: the motor module's
    dataset and decoder have the humanoid's sizes (196 proprioception, 565 future, 28 targets)."""
    experts_dir = Path(experts_dir)
    for clip in clips:
        run_dir = experts_dir / clip.removesuffix(MIRROR_SUFFIX)
        character = run_character(run_dir)
        if character != "humanoid3d":
            raise SfvError(f"{run_dir}: a {character} expert; the motor module (sfv distill, sfv one-shot) "
                           "distils humanoid3d experts only for now")
