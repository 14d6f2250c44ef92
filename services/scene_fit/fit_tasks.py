"""The scene fit's last stages as Ray tasks, so `sfv pipeline --camera moving` is one Ray job
graph from the video to the simulated motion (002 §5.3, issue 15 item 6):

    windows' trainings (Ray rollout actors) -> fit (SLSQP, one task) -> final rollout in the fitted scene
    windows' trainings                      -> final rollout in the user's scene (Table 2's "fixed scene")

The rollout in the user's scene does not wait for the fit: both start as soon as the windows
are trained, and the fitted one takes the fit's result as an object reference, so Ray runs it
the moment the fit is done. Each task reads the windows' run directories (checkpoints,
rollouts) from the shared file system, as the windows' trainings do. Without a Ray session
(the in-process callers: unit tests, a bench run without Ray) the same functions run here, in
the same order.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.scene_fit import scene_contract
from services.scene_fit.fit import FitResult, WindowTerms, fit_scene


@dataclass
class FitStages:
    fit: object | None  # fit.FitResult (None: no scene)
    initial: object | None  # final_rollout.SimulatedRun in the user's scene (None: no scene)
    simulated: object  # final_rollout.SimulatedRun in the fitted scene (or the empty arena)


def window_terms(runs) -> list[WindowTerms]:
    """Each trained window's value network and its rollouts' observations (those that reached
    the control end), the terms of eq. 14; the last window's control end is the clip's end,
    whose value is 0 (`fit.py`)."""
    from services.scene_fit.value import ValueFunction

    terms = []
    for k, run in enumerate(runs):
        rollouts = run.rollouts().handover()
        last = k == len(runs) - 1
        terms.append(WindowTerms(ValueFunction.from_run(run.train_dir), rollouts.start_obs, None if last else rollouts.end_obs))
    return terms


def fit_task(runs, scene, starts: int, seed: int) -> FitResult:
    """SLSQP on eq. 14 with every window's value network and rollouts."""
    return fit_scene(window_terms(runs), scene_contract.scene_obs(scene), scene_contract.scene_vector(scene),
                     scene_contract.scene_bounds(scene), starts=starts, seed=seed)


def rollout_task(runs, e, seed: int):
    from services.scene_fit.final_rollout import final_rollout

    return final_rollout(runs, None if e is None else np.asarray(e, np.float64), seed=seed)


def rollout_fitted_task(runs, fit, seed: int):
    """The final rollout in the scene a fit found (`fit` arrives resolved from its task)."""
    return rollout_task(runs, fit.scene, seed)


def run_fit_stages(runs, scene, seed: int, starts: int = 4, use_ray: bool | None = None) -> FitStages:
    """Fit and the two final rollouts, as Ray tasks when a Ray session is up (or `use_ray`)."""
    import ray

    remote = ray.is_initialized() if use_ray is None else use_ray
    if scene is None:
        simulated = ray.get(ray.remote(num_cpus=1)(rollout_task).remote(runs, None, seed)) if remote else rollout_task(runs, None, seed)
        return FitStages(None, None, simulated)
    e0 = scene_contract.scene_vector(scene)
    if not remote:
        fit = fit_task(runs, scene, starts, seed)
        return FitStages(fit, rollout_task(runs, e0, seed), rollout_fitted_task(runs, fit, seed))
    fit_ref = ray.remote(num_cpus=1)(fit_task).remote(runs, scene, starts, seed)
    initial_ref = ray.remote(num_cpus=1)(rollout_task).remote(runs, e0, seed)
    simulated_ref = ray.remote(num_cpus=1)(rollout_fitted_task).remote(runs, fit_ref, seed)
    fit, initial, simulated = ray.get([fit_ref, initial_ref, simulated_ref])
    return FitStages(fit, initial, simulated)
