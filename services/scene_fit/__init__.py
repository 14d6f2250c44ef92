"""Scene fitting from a moving-camera motion (dynamic-camera paper, 002 §5.3).

- `windows.py`: the clip cut into overlapping windows of at most three objects.
- `handover.py`: rollouts of one window's policy: its states where the next window starts,
  and the observations the scene fit scores.
- `sequence.py`: the windows trained in order (one `Trainer` run each, resumable).
- `value.py`: a window's value network read from its checkpoint.
- `fit.py`: the scene e maximising sum_n V_n(s(t_{n-1}), e) - V_n(s(t_n), e), SLSQP.
- `final_rollout.py`: the windows' policies chained in the fitted scene; the simulated motion.
- `fit_tasks.py`: eq. 14's terms, the fit and the final rollouts as Ray tasks (in process without Ray).
- `outputs.py`: what the pipeline writes (motion npz + BVH, the fitted scene, the summary).
- `scene_contract.py`: the one place this package meets the scene boxes and movingcam mode.
"""
