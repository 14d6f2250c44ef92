"""Videos of a trained policy: the simulated character beside a ghost of its reference.

`MUJOCO_GL` picks MuJoCo's OpenGL backend when mujoco is first imported; CPU machines have
no display, so it defaults to OSMesa (software) here unless the user chose one (egl on a
GPU host). `offscreen.gl_context_class` honours the same variable even if mujoco was
imported earlier by another module.
"""
import os

os.environ.setdefault("MUJOCO_GL", "osmesa")
