"""Running a model file on the CPU: TFLite (ai-edge-litert) or ONNX (onnxruntime).

Both backends take one NHWC float32 batch and return the named outputs as arrays, so
the detector and landmark wrappers never care which file format they were given; the
backend is picked by the file's extension.
"""
from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np

from learner.errors import SfvError

_FETCH_HINT = "run `sfv models fetch` to re-download it"


class ModelRunner(Protocol):
    input_shape: tuple[int, ...]

    def run(self, batch: np.ndarray) -> dict[str, np.ndarray]: ...


class TfliteRunner:
    """A .tflite model through ai_edge_litert's Interpreter (XNNPACK on CPU)."""

    def __init__(self, path: Path, num_threads: int = 1):
        from ai_edge_litert.interpreter import Interpreter

        try:
            self._interpreter = Interpreter(model_path=str(path), num_threads=num_threads)
            self._interpreter.allocate_tensors()
        except (ValueError, RuntimeError, OSError) as exc:
            raise SfvError(f"{path}: cannot load TFLite model ({_first_line(exc)}); {_FETCH_HINT}") from exc
        detail = self._interpreter.get_input_details()[0]
        self._input_index = detail["index"]
        self.input_shape = tuple(int(d) for d in detail["shape"])
        self._outputs = {d["name"]: d["index"] for d in self._interpreter.get_output_details()}

    def run(self, batch: np.ndarray) -> dict[str, np.ndarray]:
        self._interpreter.set_tensor(self._input_index, batch)
        self._interpreter.invoke()
        # get_tensor copies, so the arrays survive the next invoke().
        return {name: self._interpreter.get_tensor(index) for name, index in self._outputs.items()}


class OnnxRunner:
    """An .onnx model through onnxruntime's CPU provider."""

    def __init__(self, path: Path, num_threads: int = 1):
        import onnxruntime as ort

        options = ort.SessionOptions()
        options.intra_op_num_threads = num_threads
        options.inter_op_num_threads = 1
        options.log_severity_level = 3
        try:
            self._session = ort.InferenceSession(str(path), sess_options=options, providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own untyped errors for bad files
            raise SfvError(f"{path}: cannot load ONNX model ({_first_line(exc)}); {_FETCH_HINT}") from exc
        model_input = self._session.get_inputs()[0]
        self._input_name = model_input.name
        self.input_shape = tuple(int(d) if isinstance(d, int) else 1 for d in model_input.shape)
        self._output_names = [o.name for o in self._session.get_outputs()]

    def run(self, batch: np.ndarray) -> dict[str, np.ndarray]:
        values = self._session.run(self._output_names, {self._input_name: batch})
        return dict(zip(self._output_names, values, strict=True))


def open_model(path: str | Path, num_threads: int = 1) -> ModelRunner:
    """Open a model file with the backend its extension names (.tflite or .onnx)."""
    path = Path(path)
    if not path.is_file():
        raise SfvError(f"{path}: pose model not found; run `sfv models fetch` (or pass --pose-models DIR)")
    suffix = path.suffix.lower()
    if suffix == ".tflite":
        return TfliteRunner(path, num_threads)
    if suffix == ".onnx":
        return OnnxRunner(path, num_threads)
    raise SfvError(f"{path}: unknown model format {suffix!r} (expected .tflite or .onnx)")


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__
