"""Which OpenGL backend renders, chosen by what the machine has; nothing else loads GL.

MuJoCo loads the backend named by `MUJOCO_GL` when it is imported, and with a backend whose
library is missing (`MUJOCO_GL=osmesa` without libOSMesa) `import mujoco` itself fails. So:

- only rendering picks a backend (`select_backend`, called by `offscreen.gl_context`); an
  explicit `MUJOCO_GL` wins, otherwise EGL on a machine with a GPU device, else OSMesa
  (software, headless), else EGL (Mesa's software EGL), each only when its library is present;
- no library at all is one line naming the package to install (`no_gl_message`);
- `defuse_unusable_backend` (the `sfv` entry point) turns an explicit `MUJOCO_GL` whose library
  is absent into `disabled` for commands that do not render, so they still import MuJoCo.

This module imports neither mujoco nor OpenGL.
"""
from __future__ import annotations

import ctypes.util
import glob
import os
from typing import Callable, Mapping

from learner.errors import SfvError

# backend -> (library name for ctypes.util.find_library, Debian package that provides it)
BACKEND_LIBRARIES = {"egl": ("EGL", "libegl1"), "osmesa": ("OSMesa", "libosmesa6")}
DISABLED = ("disable", "disabled", "off", "false", "0")
GPU_DEVICES = ("/dev/nvidia0", "/dev/dri/renderD*")
# set by defuse_unusable_backend: the backend the user asked for, whose library is missing
REQUESTED_ENV = "SFV_MUJOCO_GL_REQUESTED"

Finder = Callable[[str], "str | None"]


def library_present(backend: str, find: Finder = ctypes.util.find_library) -> bool:
    """Whether the GL library `backend` needs is installed (True for backends not probed here)."""
    if backend not in BACKEND_LIBRARIES:
        return True
    return find(BACKEND_LIBRARIES[backend][0]) is not None


def has_gpu_device() -> bool:
    return any(glob.glob(pattern) for pattern in GPU_DEVICES)


def no_gl_message(backend: str | None = None) -> str:
    """One line naming the package to install."""
    if backend in BACKEND_LIBRARIES:
        library, package = BACKEND_LIBRARIES[backend]
        return (f"render: MUJOCO_GL={backend} but lib{library} is not installed; "
                f"run: apt-get install {package} (or unset MUJOCO_GL)")
    return ("render: no OpenGL library for off-screen rendering; run: apt-get install libosmesa6 "
            "(software) or apt-get install libegl1 (GPU), or set MUJOCO_GL")


def choose_backend(environ: Mapping[str, str] = os.environ, find: Finder = ctypes.util.find_library,
                   gpu: bool | None = None) -> str:
    """The backend to render with; SfvError (one line, naming the package) when there is none."""
    requested = environ.get(REQUESTED_ENV, "").strip().lower()
    if requested:
        raise SfvError(no_gl_message(requested))
    explicit = environ.get("MUJOCO_GL", "").strip().lower()
    if explicit in DISABLED:
        raise SfvError(f"render: MUJOCO_GL={explicit} turns rendering off; unset it or set MUJOCO_GL=egl|osmesa")
    if explicit:
        if not library_present(explicit, find):
            raise SfvError(no_gl_message(explicit))
        return explicit
    egl, osmesa = library_present("egl", find), library_present("osmesa", find)
    if egl and (has_gpu_device() if gpu is None else gpu):
        return "egl"
    if osmesa:
        return "osmesa"
    if egl:
        return "egl"
    raise SfvError(no_gl_message())


def select_backend() -> str:
    """Choose the backend and set `MUJOCO_GL` to it for this process (before mujoco's GL loads)."""
    backend = choose_backend()
    os.environ["MUJOCO_GL"] = backend
    return backend


def defuse_unusable_backend(environ: "os._Environ | dict" = os.environ, find: Finder = ctypes.util.find_library) -> None:
    """An explicit MUJOCO_GL whose library is absent would make `import mujoco` fail: set it to
    `disabled` (nothing loads GL) and remember the request, so a render says what to install."""
    explicit = environ.get("MUJOCO_GL", "").strip().lower()
    if explicit in BACKEND_LIBRARIES and not library_present(explicit, find):
        environ[REQUESTED_ENV] = explicit
        environ["MUJOCO_GL"] = "disabled"
