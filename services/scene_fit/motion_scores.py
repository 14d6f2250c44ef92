"""002 §6.2's two measures of a simulated motion against its reference (Table 2).

- MPJPE (eq. 16): mean over frames and links of the distance between the reference's and the
  simulation's link positions. Deviation: both are taken relative to their own root (pelvis)
  position, because a moving-camera reference has no root path to compare with (its
  horizontal root is a constant); the paper compares against VIBE's root-relative poses too.
- Contact accuracy: the share of (frame, foot) entries where the simulated foot's contact
  (any contact of its geom, floor or box) equals the reference's flag.
"""
from __future__ import annotations

import numpy as np


def mpjpe(reference_links: np.ndarray, simulated_links: np.ndarray) -> float:
    """(T, L, 3) world link positions each, root (link 0) first; metres."""
    ref = reference_links - reference_links[:, :1]
    sim = simulated_links - simulated_links[:, :1]
    return float(np.linalg.norm(ref - sim, axis=-1).mean())


def contact_accuracy(reference: np.ndarray, simulated: np.ndarray) -> float:
    """(T, F) bool flags each: the share that agree."""
    return float((np.asarray(reference, bool) == np.asarray(simulated, bool)).mean())


def foot_contacts(model, data, foot_geoms: np.ndarray) -> np.ndarray:
    """(F,) bool: each foot geom in at least one active contact of `data`."""
    n = data.ncon
    if n == 0:
        return np.zeros(len(foot_geoms), bool)
    touching = np.concatenate([data.contact.geom1[:n], data.contact.geom2[:n]])
    return np.isin(foot_geoms, touching)
