"""A synthetic box clip with ground truth: DeepMimic's jump, landing on a box (issue 15's box check).

`python bench/scripts/box_clip.py [--height 0.2] [--out-dir bench/scenes]` writes

- `box_jump.npz`: deepmimic:jump played once (not looped) with the root raised by the box
  height during the flight (smoothstep from take-off to landing, the frames where neither
  sole is within 4 cm of the floor), so both feet land on the box top and the rest of the
  clip stands on it. Extras: `contacts` / `contact_probability` (T, 2) right, left feet
  (sole within 5 cm of the floor or of the box top under it, the ankle slower than 1.5 m/s:
  the labels of `bench/scripts/root_path_estimate.py`, since this jump's feet hover 3-5 cm
  while they push off and a 3 cm band ends the take-off's contacts 0.2 s early; `contact_feet`),
  `box_contacts` (T, 4) int, box index or -1 per limb in `actors.envs.scene_reward.SCENE_LIMBS`
  order, the root path the moving pipeline would store (`root_path`, `root_path_confidence`:
  from the pose and those contacts, not from the true root; 1.04 m of travel against the true
  1.07, where the 3 cm labels gave 0.44), and the truth: `scene_truth` (1, 5) = along, lateral,
  height, length, width (m, scene frame: `actors.arenas.scene.SceneFrame`) with
  `scene_truth_columns`.
- `box_jump_truth.yaml`: that box as a scene file (domain +-0.1 m: the training check);
- `box_jump.yaml`: a first guess 0.1 m too far and 0.1 m too high with 002's +-0.3 m
  domains, the starting point a scene fit must correct.

Only the root's height changes: the flight is no longer exactly ballistic (the raise adds
up to ~1.5 m/s^2 of lift mid-flight at 0.2 m), which the policy absorbs as it does any
imperfect reference.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

BOX_ALONG, BOX_LENGTH, BOX_WIDTH = 1.1, 1.0, 1.0  # near edge 0.6 m: past the take-off toes, before the landing heels
FLIGHT_BAND, CONTACT_BAND = 0.04, 0.05


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def box_jump_clip(height: float = 0.2):
    """(motion, scene truth (1, 5)) of the jump landing on a box of `height` metres."""
    from actors.character.foot_contact import sole_heights
    from actors.character.kinematics import forward_kinematics
    from actors.motion.reference_motion import ReferenceMotion
    from actors.motion.formats.io import load_motion
    from actors.arenas.scene import SceneFrame

    clip = load_motion("deepmimic:jump")
    links, rots = forward_kinematics(clip.root_pos, clip.root_rot, clip.joint_rot)
    flight = np.flatnonzero(sole_heights(links, rots).min(axis=1) > FLIGHT_BAND)
    t_off, t_land = clip.frame_times[flight[0] - 1], clip.frame_times[flight[-1] + 1]
    root_pos = clip.root_pos.copy()
    root_pos[:, 2] += height * _smoothstep((clip.frame_times - t_off) / (t_land - t_off))
    links, rots = forward_kinematics(root_pos, clip.root_rot, clip.joint_rot)
    soles = sole_heights(links, rots)
    along = SceneFrame.of_motion(clip).to_scene(links[:, [5, 11], :2])[..., 0]  # right, left ankle
    over_box = np.abs(along - BOX_ALONG) < BOX_LENGTH / 2
    support = np.where(over_box, height, 0.0)
    from actors.envs.modes.movingcam.clip_cues import CONTACT_SPEED_MPS

    ankle_speed = np.linalg.norm(np.gradient(links[:, [5, 11], :2], clip.frame_times, axis=0), axis=-1)
    contacts = (soles - support < CONTACT_BAND) & (ankle_speed < CONTACT_SPEED_MPS)
    box_contacts = np.full((clip.num_frames, 4), -1, dtype=np.int64)
    box_contacts[:, :2][contacts & over_box] = 0
    truth = np.array([[BOX_ALONG, 0.0, height, BOX_LENGTH, BOX_WIDTH]])
    extras = {"contacts": contacts, "contact_probability": contacts.astype(np.float32), "contact_feet": np.array(("right", "left")),
              "box_contacts": box_contacts, "scene_truth": truth,
              "scene_truth_columns": np.array(("along", "lateral", "height", "length", "width"))}
    motion = ReferenceMotion("box_jump", clip.frame_times, root_pos, clip.root_rot, clip.joint_rot, False, extras)
    # The root path the moving pipeline stores for a root-free motion: from the pose and the
    # contacts, not the true root (services/reconstruction/root_path.py).
    from services.reconstruction.root_path import root_path_extras

    motion.extras.update(root_path_extras(motion))
    return motion, truth


def _scene_yaml(name: str, along: float, height: float, half_domain: float) -> str:
    low = round(max(0.0, height - half_domain), 6)
    return (f"# {name}\nboxes:\n  - name: box\n    along: {along:g}\n    height: {height:g}\n"
            f"    size: [{BOX_LENGTH:g}, {BOX_WIDTH:g}]\n    domain:\n      along: [{round(along - half_domain, 6):g}, {round(along + half_domain, 6):g}]\n"
            f"      height: [{low:g}, {round(height + half_domain, 6):g}]\n")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--height", type=float, default=0.2, help="box height (m)")
    parser.add_argument("--out-dir", default=str(Path(__file__).resolve().parents[2] / "bench" / "scenes"))
    args = parser.parse_args(argv)
    from actors.motion.formats.io import save_motion
    from learner.atomic_io import atomic_output

    out = Path(args.out_dir)
    motion, truth = box_jump_clip(args.height)
    save_motion(motion, out / "box_jump.npz")
    files = {"box_jump_truth.yaml": _scene_yaml("the true box of box_jump.npz", BOX_ALONG, args.height, 0.1),
             "box_jump.yaml": _scene_yaml("a first guess for box_jump.npz (truth: box_jump_truth.yaml)", BOX_ALONG + 0.1, args.height + 0.1, 0.3)}
    for name, text in files.items():
        with atomic_output(out / name) as tmp:
            Path(tmp).write_text(text)
    print(json.dumps({"motion": str(out / "box_jump.npz"), "truth": truth[0].tolist(), "frames": motion.num_frames,
                      "box_contact_frames": int((motion.extras["box_contacts"] >= 0).any(axis=1).sum())}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
