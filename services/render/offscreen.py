"""Off-screen MuJoCo rendering into numpy frames, with extra geoms added per frame.

`mujoco.Renderer` picks its GL backend once, when mujoco is imported, and owns its scene.
This class makes its own GL context with the backend `gl.py` chooses (so importing mujoco
earlier without `MUJOCO_GL` does not break headless rendering) and exposes the `MjvScene` between
`update()` and `render()`, which is where the ghost and the push arrow are added.
"""
from __future__ import annotations

import mujoco
import numpy as np

from learner.errors import SfvError
from services.render.gl import select_backend


def gl_context(width: int, height: int):
    """A GL context for off-screen rendering with the backend the machine has (`gl.py`: an
    explicit `MUJOCO_GL` wins, else EGL or OSMesa); no library or any backend failure is a
    one-line SfvError."""
    backend = select_backend()
    try:
        if backend == "osmesa":
            from mujoco.osmesa import GLContext
        elif backend == "egl":
            from mujoco.egl import GLContext
        else:
            from mujoco.glfw import GLContext
        return GLContext(width, height)
    except Exception as exc:  # noqa: BLE001  (any backend failure means: cannot render here)
        detail = str(exc).splitlines()[0] if str(exc) else ""
        raise SfvError(f"render: MuJoCo cannot render off-screen with MUJOCO_GL={backend} ({type(exc).__name__}: {detail}); "
                       "install libosmesa6 (apt-get install libosmesa6) or set MUJOCO_GL=egl") from None


class OffscreenRenderer:
    """Renders a model's scene to (height, width, 3) uint8 frames."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int, shadows: bool = False, antialias: bool = False,
                 max_geoms: int = 500):
        self.model = model
        self.width, self.height = int(width), int(height)
        # The off-screen framebuffer is made from these model fields when the render context
        # is created (visual settings only; the physics does not read them). 4x multisampling
        # costs ~2.5x the frame time in software OpenGL, hence off unless asked for.
        model.vis.global_.offwidth = self.width
        model.vis.global_.offheight = self.height
        model.vis.quality.offsamples = 4 if antialias else 0
        if self.height <= 480:
            # Coarser spheres and capsules: invisible at this size, ~25 % less CPU per frame.
            model.vis.quality.numslices, model.vis.quality.numstacks = 16, 8
        self._gl = gl_context(self.width, self.height)
        self._gl.make_current()
        self._context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._context)
        if self._context.offWidth < self.width or self._context.offHeight < self.height:
            raise SfvError(f"render: {self.width}x{self.height} exceeds the GL framebuffer limit "
                           f"{self._context.offWidth}x{self._context.offHeight}")
        self.scene = mujoco.MjvScene(model, maxgeom=max_geoms)
        self.option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()
        self._shadows = shadows
        self._viewport = mujoco.MjrRect(0, 0, self.width, self.height)
        self._rgb = np.empty((self.height, self.width, 3), np.uint8)

    # ---------------------------------------------------------------- scene
    def update(self, data: mujoco.MjData, camera: mujoco.MjvCamera) -> None:
        """Fill the scene from `data` (geoms at data's current kinematics)."""
        # The env updates kinematics without mj_camlight, so lights would still point nowhere
        # right after a reset (a dark first frame).
        mujoco.mj_camlight(self.model, data)
        mujoco.mjv_updateScene(self.model, data, self.option, self._perturb, camera, mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        # Shadows cost 3-4x the frame time in software GL; reflections are not needed.
        self.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self._shadows
        self.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False

    def add_tinted_copy(self, data: mujoco.MjData, rgba) -> int:
        """Add the moving geoms of `data` (a second pose of the same model) in one colour.

        Alpha below 1 makes MuJoCo draw them in its blended pass: a translucent ghost.
        Returns the number of geoms added.
        """
        first = self.scene.ngeom
        mujoco.mjv_addGeoms(self.model, data, self.option, self._perturb, mujoco.mjtCatBit.mjCAT_DYNAMIC, self.scene)
        for index in range(first, self.scene.ngeom):
            geom = self.scene.geoms[index]
            geom.rgba[:] = rgba
            geom.matid = -1  # no texture or material colour over the tint
        return self.scene.ngeom - first

    def add_arrow(self, start: np.ndarray, end: np.ndarray, width: float, rgba) -> None:
        if self.scene.ngeom >= self.scene.maxgeom:
            return
        geom = self.scene.geoms[self.scene.ngeom]
        mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.zeros(9), np.asarray(rgba, np.float32))
        mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_ARROW, width, np.asarray(start, np.float64), np.asarray(end, np.float64))
        self.scene.ngeom += 1

    def upload_height_fields(self) -> None:
        """Send the model's height fields to the GPU again (a terrain drawn anew for an episode:
        the context copied them when it was made)."""
        self._gl.make_current()
        for hfield in range(self.model.nhfield):
            mujoco.mjr_uploadHField(self.model, self._context, hfield)

    # --------------------------------------------------------------- pixels
    def render(self, out: np.ndarray) -> np.ndarray:
        """Draw the scene into `out` ((height, width, 3) uint8, top row first)."""
        self._gl.make_current()
        mujoco.mjr_render(self._viewport, self.scene, self._context)
        mujoco.mjr_readPixels(self._rgb, None, self._viewport, self._context)
        np.copyto(out, self._rgb[::-1])  # OpenGL's first row is the bottom one
        return out

    def close(self) -> None:
        if self._context is not None:
            self._gl.make_current()
            self._context.free()
            self._context = None
        if self._gl is not None:
            self._gl.free()
            self._gl = None

    def __enter__(self) -> "OffscreenRenderer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
