"""The registered run specs: the configurations behind the numbers in README.md and docs/.

Budgets are the ones each result was measured at; workers x envs per worker is the 2 x 32 every
humanoid row used (a different machine changes the wall time, not the settings). Each spec's
`report` is the JSON under bench/results/ (or the report page under bench/reports/) that holds its
numbers.
"""
from __future__ import annotations

from services.specs.spec import RunSpec, register

MIO = 1_000_000
LEARNING = "bench/results/learning_all/learning.json"
SKILL_SAMPLES = {  # the skills table: each clip's budget
    "walk": 2 * MIO, "run": 3 * MIO, "jump": 4 * MIO, "cartwheel": 10 * MIO, "backflip": 20 * MIO,
    "dance_a": 7 * MIO, "dance_b": 11 * MIO, "crawl": 2 * MIO, "getup_facedown": 2 * MIO, "getup_faceup": 2 * MIO,
    "roll": 5 * MIO, "punch": 2 * MIO, "kick": 2 * MIO, "spinkick": 6 * MIO, "spin": 20 * MIO,
}
G1_ROWS = {  # the G1 table: clip -> (budget, its evaluation)
    "walk": (3 * MIO, "bench/results/g1/g1_walk_per_joint_eval.json"),
    "run": (4 * MIO, "bench/results/g1/g1_run_per_joint_eval.json"),
    "jump": (4 * MIO, "bench/results/g1/g1_jump_eval.json"),
    "cartwheel": (5 * MIO, "bench/results/g1/g1_cartwheel_eval.json"),
}
SKILL_REPORTS = {  # clips retrained or re-evaluated since the suite's record
    "cartwheel": "bench/results/start_filter/learning.json", "roll": "bench/results/start_filter/learning.json",
    "backflip": "bench/results/learning_all/backflip_20m_eval.json",
}
WORKERS = {"workers": 2, "envs_per_worker": 32}

for clip, samples in SKILL_SAMPLES.items():
    register(RunSpec(clip.replace("_", "-"), "train", f"DeepMimic's {clip} on the humanoid, {samples / MIO:g} M samples (skills table)",
                     {"motion": f"deepmimic:{clip}", "samples": samples, **WORKERS}, SKILL_REPORTS.get(clip, LEARNING)))

for clip, (samples, report) in G1_ROWS.items():
    register(RunSpec(f"g1-{clip}", "train", f"DeepMimic's {clip} retargeted onto the Unitree G1, {samples / MIO:g} M samples",
                     {"motion": f"deepmimic:{clip}", "env.character": "g1", "samples": samples, **WORKERS}, report))

for init in ("asi", "rsi", "fsi"):
    register(RunSpec(f"table2-cartwheel-{init}", "train", f"SFV's Table 2 cell: the cartwheel from {init.upper()} starts, 3 M samples "
                     "(seeds 0-2: --seed)", {"motion": "deepmimic:cartwheel", "init": init, "samples": 3 * MIO, **WORKERS},
                     "bench/results/table2_cartwheel/init_comparison.json"))


# The static video pipeline's training (`sfv pipeline`, services/commands/_pipeline_settings.py
# reads it): sfv train's 200 k default is a quick first run on any clip, while a user's video should
# end in a controller that completes the clip from its first frame. Pose2Sim, one worker, 2 M samples:
# with ASI's uniform phases alone the first frames got a ninth of the last frames' samples and cam01's
# controller fell at 1.5 s of the 1.67 s clip; with half the episodes started at the first frame
# (`first_frame_share`) cam01 and cam03 both complete it upright (NR .767 and .849).
# A residual root wrench (`env.residual_force`, at most half the body weight; actors/envs/residual_force.py):
# a reconstruction fitted to the skeleton, not to its masses, asks for balances the humanoid's joints
# alone cannot hold. Balancing cam01, same reconstruction: the simulated motion's PA-MPJPE against the
# markers 115.2 -> 73.1 mm (kinematic 70.5), its tracking error 130 -> 22 mm, NR .77 -> .91, using
# 11 % of body weight on average (docs/video.md).
register(RunSpec("pipeline-static", "pipeline", "the video pipeline's training, static camera (sfv pipeline's defaults)",
                 {"samples": 2 * MIO, "first_frame_share": 0.5, "env.residual_force": 0.5}, "bench/results/videos.json"))

NPMP_TASK_SAMPLES = {"go_to": 2 * MIO, "push_box": 600_000}  # the tasks table
for task, samples in NPMP_TASK_SAMPLES.items():
    for action in ("latent", "joint"):
        register(RunSpec(f"npmp-{task.replace('_', '-')}-{action}", "task",
                         f"{task} with {action} actions{' on the motor module (--module)' if action == 'latent' else ' from scratch'}, "
                         f"{samples / MIO:g} M samples", {"env.task": task, "env.action": action, "samples": samples,
                                                          "workers": 2, "envs_per_worker": 16}, "bench/results/npmp_tasks.json"))

NPMP_CLIPS = ("walk", "run", "cartwheel", "crawl", "getup_facedown", "walk_left", "kick")  # walk_left: the turning walk
register(RunSpec("npmp-module", "distill", "the motor module of the one-shot table: 7 clips and their mirrors, kick held out",
                 {"steps_per_clip": 12_000, "clips": (*NPMP_CLIPS, *(f"{clip}_mirror" for clip in NPMP_CLIPS)),
                  "hold_out": ("kick", "kick_mirror"), "beta": 0.1}, "bench/results/npmp/one_shot.json"))
# The shipped module (`--module pretrained`; bench/scripts/npmp_pretrained.py makes it from nothing):
# locomotion with turns, the experts' directory holding walk_turn30/60 trained from `sfv motion bend` files.
PRETRAINED_CLIPS = ("walk", "run", "walk_turn30", "walk_turn60")
register(RunSpec("npmp-pretrained", "distill", "the shipped motor module: walk, run, 30 and 60 deg/s turning walks and their mirrors, "
                 "walk_turn30_mirror held out", {"steps_per_clip": 12_000, "clips": (*PRETRAINED_CLIPS, *(f"{c}_mirror" for c in PRETRAINED_CLIPS)),
                                                  "hold_out": ("walk_turn30_mirror",), "beta": 0.3}, "bench/results/npmp/levers.json"))
