"""The moving-camera pipeline's training budget per window (`sfv pipeline --camera moving`).

`--samples` (TrainConfig.samples) is the budget of each window's training; the pipeline's own
default is WINDOW_SAMPLES, not `sfv train`'s 200 k (a quick first run): with 200 k a real
312-frame court video's one window fell at frame 39 and simulated.npz held 40 frames (issue 48).

Measured on this machine (2 cores shared with other trainings, 2 process workers x 16-32 envs):
- the synthetic moving-camera walk (`bench/results/movingcam_synthetic.json`, 002's tracking):
  every evaluation episode falls at 500 k samples (2.2 s), NR .53 with 62 % upright at 1 M, .46
  at 1.5 M; 1.5 M took 16.5 min (11 min per million);
- the box jump's window (`bench/results/scene_fit.json`, `scene_fit_fsi.json`): 2 M samples, then
  the fit and the rollouts, in 777 s and 786 s (6.5 min per million): 6 of 8 (RSI) and 8 of 8 (FSI)
  rollouts reach the window's control end;
- the run (`movingcam_synthetic_run.json`) still falls within 1 s at 1 M.
2 M is the least measured budget at which a window's policy reaches its control end, and the
static pipeline's budget (`pipeline-static`), so a window costs what a static clip does:
about 13-22 minutes on 2 shared cores (MINUTES_PER_MILLION).
"""
from __future__ import annotations

WINDOW_SAMPLES = 2_000_000
MINUTES_PER_MILLION = (6.5, 11.0)  # the box jump's window and the synthetic walk above
# The path cue's weight (actors/envs/modes/movingcam/path_cue.py); every motion the pipeline
# reconstructs carries root_path. Measured on the synthetic moving-camera walk with the contact
# estimate of its path (`docs/moving-camera-path.md`, one seed, 16 episodes, both arms falling in
# all): start-to-end travel .68 of the truth's at 1 M samples against .55 without (.64 / .59 at
# 600 k), path error .39 / .46 per metre, survival 2.85 / 3.04 s (within the episodes' spread).
PATH_WEIGHT = 0.2


def moving_defaults() -> dict:
    """The moving pipeline's training defaults ({config path: value}); a flag or --config wins."""
    return {"samples": WINDOW_SAMPLES, "env.movingcam.path_weight": PATH_WEIGHT}


def minutes_per_window(samples: int) -> tuple[float, float]:
    """The measured range of wall minutes one window's training takes on 2 shared cores."""
    return tuple(round(rate * samples / 1e6, 1) for rate in MINUTES_PER_MILLION)
