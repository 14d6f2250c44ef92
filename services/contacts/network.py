"""The contact network (movingcam section 6): four fully connected layers of 1024, 512, 128
and 32 units, each with batch normalisation and ReLU, then a linear layer giving one contact
logit per foot (right, left). The paper names the layer widths and batch norm; the ReLU and
the sigmoid-per-foot output (two independent contacts, trained with binary cross-entropy)
are this project's reading of "a contact flag per foot"."""
from __future__ import annotations

import warnings

import torch
from torch import nn

from services.contacts.features import FEATURES

HIDDEN = (1024, 512, 128, 32)
FEET = ("right", "left")


def contact_network() -> nn.Sequential:
    layers: list[nn.Module] = []
    width = FEATURES
    for units in HIDDEN:
        layers += [nn.Linear(width, units), nn.BatchNorm1d(units), nn.ReLU()]
        width = units
    layers.append(nn.Linear(width, len(FEET)))
    return nn.Sequential(*layers)


def export_onnx(network: nn.Sequential, path) -> None:
    """Eval-mode export (batch norm folded to its running statistics), dynamic batch size."""
    network.eval()
    example = torch.zeros(2, FEATURES)
    with warnings.catch_warnings():  # the TorchScript exporter is deprecated but gives a plain, small graph
        warnings.simplefilter("ignore", DeprecationWarning)
        torch.onnx.export(network, example, str(path), input_names=["windows"], output_names=["contact_logits"],
                          dynamic_axes={"windows": {0: "batch"}, "contact_logits": {0: "batch"}}, opset_version=17,
                          dynamo=False)
