"""Foot contacts of a video's subject from the shipped ONNX network (onnxruntime, no torch).

The model file's SHA-256 is checked against `foot_contact.sha256` when it is opened: a file
changed by hand (or half copied) is refused with the command that rebuilds it.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from learner.errors import SfvError
from services.contacts.features import FEATURES, frame_stride, window_features
from services.contacts.settings import DIGEST_FILE, MODEL_FILE

SHIPPED = Path(__file__).resolve().parent / "weights"
CONTACT_THRESHOLD = 0.5
RETRAIN = "sfv contacts-train --out services/contacts/weights"


def _checked(directory: Path) -> Path:
    model, digest_file = directory / MODEL_FILE, directory / DIGEST_FILE
    if not model.is_file() or not digest_file.is_file():
        raise SfvError(f"{model}: foot-contact model or its digest missing; rebuild with `{RETRAIN}`")
    expected = digest_file.read_text().split()[0]
    actual = hashlib.sha256(model.read_bytes()).hexdigest()
    if actual != expected:
        raise SfvError(f"{model}: checksum {actual[:12]}... does not match {digest_file.name} ({expected[:12]}...); "
                       f"rebuild with `{RETRAIN}`")
    return model


class FootContactEstimator:
    def __init__(self, directory: str | Path = SHIPPED):
        import onnxruntime as ort

        options = ort.SessionOptions()
        options.intra_op_num_threads = 1
        options.log_severity_level = 3
        model = _checked(Path(directory))
        self._session = ort.InferenceSession(str(model), sess_options=options, providers=["CPUExecutionProvider"])
        self._input = self._session.get_inputs()[0].name
        if self._session.get_inputs()[0].shape[-1] != FEATURES:
            raise SfvError(f"{model}: expects {self._session.get_inputs()[0].shape[-1]} features, not {FEATURES}")

    def estimate(self, points2d: np.ndarray, confidence: np.ndarray, fps: float) -> np.ndarray:
        """(T, 2) contact probabilities (right, left foot) from (T, 17, 2) fit points and (T, 17) confidences."""
        windows = window_features(points2d, confidence, frame_stride(fps))
        (logits,) = self._session.run(None, {self._input: windows})
        return 1.0 / (1.0 + np.exp(-logits.astype(np.float64)))


def track_contacts(track, label_flipped: np.ndarray | None = None,
                   estimator: FootContactEstimator | None = None, static_camera: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(T, 2) probabilities and (T, 2) flags (right, left) for a `services.pose.PoseTrack`,
    read with the left/right corrections the reconstruction made (`label_flipped`). A flag is a
    probability of at least CONTACT_THRESHOLD; under a static camera a foot that stays put in the
    picture while the body travels is down too (`services/contacts/planted.py`); and a walker's
    short gaps with no foot down get the likelier foot (`supported`)."""
    from services.reconstruction.keypoints import observe
    from services.reconstruction.label_flips import undo_label_flips

    observed = observe(track)
    if label_flipped is not None:
        observed = undo_label_flips(observed, np.asarray(label_flipped, bool))
    probabilities = (estimator or FootContactEstimator()).estimate(observed.keypoints2d, observed.confidence, track.fps)
    flags = probabilities >= CONTACT_THRESHOLD
    if static_camera:
        flags |= planted(observed, track.fps)
    return probabilities, supported(flags, probabilities, observed, track.fps)


def planted(observed, fps: float) -> np.ndarray:
    """(T, 2) feet planted in a static camera's picture while the body travels (right, left)."""
    from services.contacts.planted import planted_feet
    from services.reconstruction.keypoints import fit_index

    feet = [[fit_index(f"{side}{point}") for point in ("Heel", "Ankle", "Toe")] for side in ("R", "L")]
    return planted_feet(observed.keypoints2d, observed.confidence, fps, [fit_index("RHip"), fit_index("LHip")], feet)


def supported(flags: np.ndarray, probabilities: np.ndarray, observed, fps: float) -> np.ndarray:
    """`flags` with a walker's missed support put down (`services/contacts/support.py`)."""
    from services.contacts.support import fill_missed_support, hip_pace, keypoint_span
    from services.reconstruction.keypoints import fit_index

    span = keypoint_span(observed.keypoints2d, observed.confidence)
    pace = hip_pace(observed.keypoints2d, [fit_index("RHip"), fit_index("LHip")], span, fps)
    return fill_missed_support(flags, probabilities, pace, fps)[0]
