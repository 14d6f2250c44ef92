"""The motor decoder as ONNX (`MODULE/decoder.onnx`), built from the decoder.npz arrays (no tracing).

    proprio [batch, 196], z [batch, latent] -> Concat(clip((proprio - mean) / std), z)
        -> (MatMul, Add, Elu)* -> MatMul, Add -> targets [batch, 28]   (absolute PD targets, rad)

The decoder's std travels in the metadata (`action_std`, JSON). `OnnxLatentDecoder` runs it with
onnxruntime with the same call as `learner.motor_decoder.LatentDecoder`.
"""
from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper

from learner.atomic_io import atomic_write_bytes
from learner.errors import SfvError
from learner.motor_decoder import decoder_layers
from learner.onnx_export import IR_VERSION, OPSET, normalised_mlp

INPUTS = ("proprio", "z")
OUTPUT = "targets"


def build_decoder_onnx(weights: Mapping[str, np.ndarray]) -> onnx.ModelProto:
    layers = decoder_layers(weights)
    clip = float(np.asarray(weights["input_clip"]))

    initializers, nodes = normalised_mlp("proprio", weights["proprio_mean"], weights["proprio_std"], clip, layers, OUTPUT,
                                         "Elu", extra_inputs=("z",), alpha=1.0)
    proprio_dim, latent_dim = int(np.shape(weights["proprio_mean"])[0]), int(weights["latent_dim"])
    graph = helper.make_graph(
        nodes, "sfv_motor_decoder",
        [helper.make_tensor_value_info("proprio", TensorProto.FLOAT, ["batch", proprio_dim]),
         helper.make_tensor_value_info("z", TensorProto.FLOAT, ["batch", latent_dim])],
        [helper.make_tensor_value_info(OUTPUT, TensorProto.FLOAT, ["batch", layers[-1][0].shape[1]])],
        initializers)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="sfv", ir_version=IR_VERSION)
    helper.set_model_props(model, {"action_std": json.dumps([float(v) for v in np.asarray(weights["action_std"])])})
    onnx.checker.check_model(model)
    return model


def export_decoder_onnx(weights: Mapping[str, np.ndarray], path: str | os.PathLike) -> Path:
    return atomic_write_bytes(path, build_decoder_onnx(weights).SerializeToString())


class OnnxLatentDecoder:
    def __init__(self, path: str | os.PathLike, num_threads: int = 1):
        import onnxruntime

        self.path = Path(path)
        if not self.path.is_file():
            raise SfvError(f"{self.path}: ONNX motor decoder not found")
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = num_threads
        try:
            self._session = onnxruntime.InferenceSession(str(self.path), sess_options=options, providers=["CPUExecutionProvider"])
            self.action_std = np.asarray(json.loads(self._session.get_modelmeta().custom_metadata_map["action_std"]), np.float32)
        except Exception as exc:  # onnxruntime raises its own exception types
            raise SfvError(f"{self.path}: not a valid sfv motor decoder ({type(exc).__name__}: {' '.join(str(exc).split())[:200]})") from exc

    def __call__(self, proprio: np.ndarray, z: np.ndarray) -> np.ndarray:
        feeds = {"proprio": np.ascontiguousarray(proprio, np.float32), "z": np.ascontiguousarray(z, np.float32)}
        return self._session.run([OUTPUT], feeds)[0]
