"""Export the deterministic policy to ONNX, and run such a file without torch.

The graph is built straight from `PPOLearner.policy_weights()` (no torch tracing):

    obs [batch, obs_dim] -> clip((obs - mean) / std) -> (MatMul, Add, Relu)* -> MatMul, Add -> action_mean [batch, act_dim]

The fixed action std travels in the model's metadata (``action_std``, a JSON list), so
`OnnxPolicy` can also sample, with the same `act()` contract as `learner.policy.NumpyPolicy`;
a caller may add its own string properties (`sfv export --onnx`: what a robot runtime needs).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from learner.atomic_io import atomic_write_bytes
from learner.errors import SfvError
from learner.policy import diagonal_gaussian_logp, gaussian_log_normaliser, policy_layers

OPSET = 17
# onnxruntime lags onnx's newest IR version; 8 is what opset 17 needs and any recent runtime reads.
IR_VERSION = 8
INPUT_NAME = "obs"
OUTPUT_NAME = "action_mean"


def onnx_constant(name: str, value) -> onnx.TensorProto:
    return numpy_helper.from_array(np.asarray(value, dtype=np.float32), name)


def normalised_mlp(input_name: str, mean, std, clip: float, layers, output: str, activation: str,
                   extra_inputs: tuple[str, ...] = (), **activation_attrs) -> tuple[list, list]:
    """Initializers and nodes of clip((x - mean) / std) [concatenated with `extra_inputs`]
    through the MLP `layers` ((weight (in, out), bias) pairs, `activation` between them): the
    graph both the policy mean and the motor decoder export."""
    initializers = [onnx_constant("obs_mean", mean), onnx_constant("obs_std", std),
                    onnx_constant("obs_clip_min", np.array(-clip)), onnx_constant("obs_clip_max", np.array(clip))]
    clipped = "obs_clipped" if extra_inputs else "hidden_in0"
    nodes = [helper.make_node("Sub", [input_name, "obs_mean"], ["obs_centred"]),
             helper.make_node("Div", ["obs_centred", "obs_std"], ["obs_scaled"]),
             helper.make_node("Clip", ["obs_scaled", "obs_clip_min", "obs_clip_max"], [clipped])]
    if extra_inputs:
        nodes.append(helper.make_node("Concat", [clipped, *extra_inputs], ["hidden_in0"], axis=1))
    last = len(layers) - 1
    for index, (weight, bias) in enumerate(layers):
        initializers += [onnx_constant(f"layer{index}.weight", weight), onnx_constant(f"layer{index}.bias", bias)]
        nodes.append(helper.make_node("MatMul", [f"hidden_in{index}", f"layer{index}.weight"], [f"matmul{index}"]))
        pre_activation = output if index == last else f"pre_activation{index}"
        nodes.append(helper.make_node("Add", [f"matmul{index}", f"layer{index}.bias"], [pre_activation]))
        if index != last:
            nodes.append(helper.make_node(activation, [pre_activation], [f"hidden_in{index + 1}"], **activation_attrs))
    return initializers, nodes


def build_policy_onnx(policy_weights: Mapping[str, np.ndarray], metadata: Mapping[str, str] | None = None) -> onnx.ModelProto:
    """An ONNX model of the policy mean with the observation normalisation baked in; `metadata`:
    more string properties for the file (a robot runtime's, `services/export/runtime_metadata.py`)."""
    layers = policy_layers(policy_weights)
    obs_dim = int(np.shape(policy_weights["obs_mean"])[0])
    act_dim = layers[-1][0].shape[1]

    clip = float(np.asarray(policy_weights["obs_clip"]))
    initializers, nodes = normalised_mlp(INPUT_NAME, policy_weights["obs_mean"], policy_weights["obs_std"], clip, layers,
                                         OUTPUT_NAME, "Relu")

    graph = helper.make_graph(
        nodes,
        "sfv_policy_mean",
        [helper.make_tensor_value_info(INPUT_NAME, TensorProto.FLOAT, ["batch", obs_dim])],
        [helper.make_tensor_value_info(OUTPUT_NAME, TensorProto.FLOAT, ["batch", act_dim])],
        initializers,
    )
    model = helper.make_model(
        graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="sfv", ir_version=IR_VERSION
    )
    action_std = [float(value) for value in np.asarray(policy_weights["action_std"], dtype=np.float32)]
    extra = dict(metadata or {})
    if "action_std" in extra:
        raise ValueError("internal: action_std is the policy's own metadata")
    helper.set_model_props(model, {"action_std": json.dumps(action_std), **extra})
    onnx.checker.check_model(model)
    return model


def export_policy_onnx(policy_weights: Mapping[str, np.ndarray], path: str | os.PathLike,
                       metadata: Mapping[str, str] | None = None) -> Path:
    """Write the policy-mean ONNX model atomically to `path` (with `metadata` properties)."""
    return atomic_write_bytes(path, build_policy_onnx(policy_weights, metadata).SerializeToString())


class OnnxPolicy:
    """An exported policy run with onnxruntime; same `act()` contract as NumpyPolicy."""

    def __init__(self, path: str | os.PathLike, num_threads: int = 0) -> None:
        import onnxruntime

        self.path = Path(path)
        if not self.path.is_file():
            raise SfvError(f"{self.path}: ONNX policy not found")
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = num_threads
        try:
            self._session = onnxruntime.InferenceSession(
                str(self.path), sess_options=options, providers=["CPUExecutionProvider"]
            )
            metadata = self._session.get_modelmeta().custom_metadata_map
            self.metadata = dict(metadata)  # the file's string properties (a robot runtime's among them)
            self._action_std = np.asarray(json.loads(metadata["action_std"]), dtype=np.float32)
        except Exception as exc:  # onnxruntime raises its own exception types
            reason = " ".join(str(exc).split())[:200]
            raise SfvError(f"{self.path}: not a valid sfv ONNX policy ({type(exc).__name__}: {reason})") from exc
        self.obs_dim = int(self._session.get_inputs()[0].shape[1])
        self.act_dim = int(self._action_std.shape[0])
        self._log_normaliser = gaussian_log_normaliser(self._action_std)

    def mean(self, obs: np.ndarray) -> np.ndarray:
        obs = np.ascontiguousarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] != self.obs_dim:
            raise ValueError(f"OnnxPolicy: obs must be (M, {self.obs_dim}), got {obs.shape}")
        return self._session.run([OUTPUT_NAME], {INPUT_NAME: obs})[0]

    def act(
        self, obs: np.ndarray, rng: np.random.Generator | None = None, deterministic: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """(actions (M, act_dim), logp (M,)); the mean unless deterministic=False."""
        mean = self.mean(obs)
        actions = mean.copy()
        if not deterministic:
            if rng is None:
                raise ValueError("OnnxPolicy.act: a np.random.Generator is required unless deterministic=True")
            actions += self._action_std * rng.standard_normal(mean.shape, dtype=np.float32)
        logp = np.empty(mean.shape[0], dtype=np.float32)
        diagonal_gaussian_logp(actions, mean, self._action_std, self._log_normaliser, np.empty_like(mean), logp)
        return actions, logp
