"""SSD anchors of the BlazePose person detector.

Generated the way MediaPipe's SsdAnchorsCalculator does for the pose detection graph:
5 layers with strides 8, 16, 32, 32, 32 on a 224x224 input, one aspect ratio plus one
interpolated scale per layer (2 anchors per cell per layer), fixed anchor size and
cell-centre offsets of 0.5. Consecutive layers with the same stride share one feature
map, so the 7x7 map carries 3 x 2 = 6 anchors per cell:
28*28*2 + 14*14*2 + 7*7*6 = 2254.
"""
from __future__ import annotations

import numpy as np

DETECTOR_INPUT_SIZE = 224
DETECTOR_STRIDES = (8, 16, 32, 32, 32)
ANCHORS_PER_LAYER = 2  # aspect ratio 1.0 + the interpolated scale


def ssd_anchor_centres(input_size: int = DETECTOR_INPUT_SIZE, strides: tuple[int, ...] = DETECTOR_STRIDES,
                       anchors_per_layer: int = ANCHORS_PER_LAYER, offset: float = 0.5) -> np.ndarray:
    """(N, 2) anchor centres (x, y), normalised to [0, 1], in the model's output order.

    With fixed_anchor_size every anchor's width and height is 1, so only centres matter.
    """
    blocks = []
    layer = 0
    while layer < len(strides):
        stride = strides[layer]
        layers_in_group = 0
        while layer < len(strides) and strides[layer] == stride:
            layers_in_group += 1
            layer += 1
        cells = int(np.ceil(input_size / stride))
        ys, xs = np.meshgrid((np.arange(cells) + offset) / cells, (np.arange(cells) + offset) / cells, indexing="ij")
        centres = np.stack([xs.ravel(), ys.ravel()], axis=1)  # row-major: y outer, x inner
        blocks.append(np.repeat(centres, layers_in_group * anchors_per_layer, axis=0))
    return np.concatenate(blocks).astype(np.float32)
