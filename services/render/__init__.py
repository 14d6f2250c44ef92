"""Videos: a trained policy beside a ghost of its reference (`movie.py`), a reconstruction
beside its video (`motion_video.py`), a retargeted clip beside its source skeleton
(`source_skeleton.py`); one off-screen renderer and one MP4 writer for all of them.

The OpenGL backend is chosen when a renderer makes its GL context (`gl.py`: an explicit
`MUJOCO_GL` wins, otherwise EGL or OSMesa, whichever the machine has); importing this package
sets nothing, so code that only uses its helpers (pushes, cameras) never loads GL.
"""
