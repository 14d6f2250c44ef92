"""Videos: a trained policy beside a ghost of its reference (`movie.py`), a reconstruction
beside its video (`motion_video.py`), a retargeted clip beside its source skeleton
(`source_skeleton.py`); one off-screen renderer and one MP4 writer for all of them.

`MUJOCO_GL` picks MuJoCo's OpenGL backend when mujoco is first imported; CPU machines have
no display, so it defaults to OSMesa (software) here unless the user chose one (egl on a
GPU host). `offscreen.gl_context` honours the same variable even if mujoco was
imported earlier by another module.
"""
import os

os.environ.setdefault("MUJOCO_GL", "osmesa")
