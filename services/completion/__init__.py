"""Motion completion (SFV section 8): predict an actor's motion from one still image.

    from services.completion.pipeline import complete_motion
    summary = complete_motion("jump.png", ["runs/walk", "runs/run"], "jump.mp4")

The image's 3D pose is estimated (BlazePose), fitted to the humanoid (q_bar), compared with
every frame of every library run's reference motion, and the closest run's policy is
simulated from q_bar with the chosen frame's velocities; the result is filmed beside the image.

Nothing is imported here, so that `sfv --help` (which registers every command) does not
load torch and MuJoCo.
"""
