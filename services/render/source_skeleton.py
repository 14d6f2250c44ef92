"""Side-by-side video of a retargeting: the source BVH skeleton as a stick figure (left) and the
retargeted humanoid (right), both rendered by MuJoCo from the same camera following the root.

The source is drawn in the humanoid's axes and at its size (the retargeter's `SourceFrame`:
axes detected or given, lengths times the leg-length ratio) and translated once so that its
hips sit on the humanoid's root in the first frame; after that both move on their own, so a
drifting root or a wrong floor shows. Bones of the source's right side are orange, left blue,
the rest white; joints that drive a humanoid link are large dots, folded ones small grey dots.
"""
from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from actors.motion.formats.bvh import read_bvh
from actors.motion.formats.bvh_pose import bvh_forward_kinematics
from actors.character.humanoid3d import Humanoid
from actors.motion.reference_motion import ReferenceMotion
from actors.motion.formats.retarget import RetargetOptions, source_frame
from actors.motion.formats.rigs import resolve_rig
from actors.character.state import StateLayout
from services.render.camera import CameraConfig, FollowCamera
from services.render.caption import WHITE, draw_lines, text_scale
from services.render.offscreen import OffscreenRenderer
from services.render.video_writer import AtomicVideoWriter

RIGHT_RGBA, LEFT_RGBA, CENTRE_RGBA, FOLDED_RGBA = (1.0, 0.45, 0.15, 1.0), (0.2, 0.55, 1.0, 1.0), (0.95, 0.95, 0.95, 1.0), (0.6, 0.6, 0.6, 1.0)
MAX_FPS = 30.0
BONE_RADIUS, MAPPED_RADIUS, FOLDED_RADIUS = 0.018, 0.035, 0.02


def _sides(parents: list[int], index: dict) -> list[str]:
    """'right', 'left' or 'centre' per source joint: below a mapped right/left hip or shoulder."""
    starts = {index[t]: t.split("_")[0] for t in ("right_hip", "right_shoulder", "left_hip", "left_shoulder")}
    sides = []
    for joint, parent in enumerate(parents):
        sides.append(starts.get(joint, sides[parent] if parent >= 0 else "centre"))
    return sides


def _add_geom(scene: mujoco.MjvScene, kind, size, rgba, start=None, end=None, centre=None) -> None:
    if scene.ngeom >= scene.maxgeom:
        return
    geom = scene.geoms[scene.ngeom]
    mujoco.mjv_initGeom(geom, kind, np.full(3, size), np.zeros(3) if centre is None else centre, np.eye(3).ravel(),
                        np.asarray(rgba, np.float32))
    if start is not None:
        mujoco.mjv_connector(geom, kind, size, np.asarray(start, np.float64), np.asarray(end, np.float64))
    scene.ngeom += 1


class SourcePanel:
    """The stick figure drawn into an `OffscreenRenderer`'s scene (floor only, no humanoid)."""

    def __init__(self, renderer: OffscreenRenderer, parents: list[int], index: dict):
        self.renderer, self.parents = renderer, parents
        self.sides = _sides(parents, index)
        self.mapped = set(index.values())
        self._perturb = mujoco.MjvPerturb()

    def draw(self, data: mujoco.MjData, camera: mujoco.MjvCamera, points: np.ndarray, out: np.ndarray) -> np.ndarray:
        renderer = self.renderer
        mujoco.mjv_updateScene(renderer.model, data, renderer.option, self._perturb, camera, mujoco.mjtCatBit.mjCAT_STATIC, renderer.scene)
        scene = renderer.scene
        colour = {"right": RIGHT_RGBA, "left": LEFT_RGBA, "centre": CENTRE_RGBA}
        for joint, parent in enumerate(self.parents):
            if parent >= 0 and np.linalg.norm(points[joint] - points[parent]) > 1e-6:
                _add_geom(scene, mujoco.mjtGeom.mjGEOM_CAPSULE, BONE_RADIUS, colour[self.sides[joint]], points[parent], points[joint])
        for joint in range(len(self.parents)):
            mapped = joint in self.mapped
            _add_geom(scene, mujoco.mjtGeom.mjGEOM_SPHERE, MAPPED_RADIUS if mapped else FOLDED_RADIUS,
                      colour[self.sides[joint]] if mapped else FOLDED_RGBA, centre=points[joint])
        return renderer.render(out)


def render_source_video(motion: ReferenceMotion, source: Path, out: Path, height: int = 480, rig: str = "auto",
                        options: RetargetOptions | None = None) -> int:
    """Write the MP4 (atomically); returns the number of frames."""
    options = options or RetargetOptions()
    bvh = read_bvh(source)
    rig_map = resolve_rig(rig, [j.name for j in bvh.joints], source)
    frame = source_frame(bvh, rig_map, options, source)
    positions, _ = bvh_forward_kinematics(bvh)
    points = frame.to_humanoid(positions)  # (T, J, 3)
    hips = 0.5 * (points[:, frame.index["right_hip"]] + points[:, frame.index["left_hip"]])
    points += motion.root_pos[0] - hips[0]

    width = 2 * round(height / 3)
    humanoid = Humanoid()
    layout = StateLayout(humanoid)
    data = mujoco.MjData(humanoid.model)
    camera = FollowCamera(CameraConfig(smoothing=1.0))
    fps = min(MAX_FPS, motion.fps)
    times = np.arange(0.0, min(motion.duration, (len(bvh.frames) - 1) * bvh.frame_time) + 1e-9, 1.0 / fps)
    left, right = np.empty((height, width, 3), np.uint8), np.empty((height, width, 3), np.uint8)
    with OffscreenRenderer(humanoid.model, width, height) as renderer, AtomicVideoWriter(out, fps) as video:
        panel = SourcePanel(renderer, [j.parent for j in bvh.joints], frame.index)
        title = f"source {source.name} ({rig_map.name})"
        scale = text_scale(width, height, [title, "retargeted humanoid"])
        for t in times:
            pose = motion.sample(t)
            layout.pose_to_qpos_qvel(pose, data.qpos, data.qvel)
            mujoco.mj_kinematics(humanoid.model, data)
            camera.snap(pose.root_pos[:2])
            renderer.update(data, camera.camera)
            renderer.render(right)
            source_frame_index = min(round(t / bvh.frame_time), len(bvh.frames) - 1)
            panel.draw(data, camera.camera, points[source_frame_index], left)
            draw_lines(left, [(title, WHITE), (f"t {t:.2f} s", WHITE)], scale)
            draw_lines(right, [("retargeted humanoid", WHITE)], scale)
            video.append(np.concatenate((left, right), axis=1))
        return video.frames
