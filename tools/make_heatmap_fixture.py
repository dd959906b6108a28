#!/usr/bin/env python3
"""Writes a tiny synthetic ONNX "heatmap keypoint network" for the heatmap-path test.

Input [1, 3, 64, 64] (NCHW), output [1, 22, 8, 8]: 21 joint heatmaps + one background map,
like OpenPose's hand model (which outputs 22 maps). The maps do not depend on the image
content except through a zero-weight convolution (so the graph really consumes the input):
joint j has a Gaussian peak centred at a known, non-integer cell position, so the test can
check peak finding, sub-pixel refinement, the crop -> image mapping and the mirroring of
one-sided networks end to end. Positions are written to heatmap_fixture.json.

    /tmp/litert-venv/bin/pip install onnx numpy
    /tmp/litert-venv/bin/python tools/make_heatmap_fixture.py crates/monohand-vision/tests/fixtures
"""
import json
import os
import sys

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

out_dir = sys.argv[1]
H = W = 8
maps = np.zeros((1, 22, H, W), dtype=np.float32)
peaks = []
ys, xs = np.mgrid[0:H, 0:W]
for j in range(21):
    # Peak centres in cell-centre coordinates (cell i centre = i), spread over the map.
    cx = 1.3 + (j % 5) * 1.2
    cy = 1.6 + (j // 5) * 1.1
    maps[0, j] = 0.9 * np.exp(-((xs - cx) ** 2 + (ys - cy) ** 2) / (2 * 0.8 ** 2))
    peaks.append([cx + 0.5, cy + 0.5])  # continuous coordinates (cell i spans [i, i+1))
maps[0, 21] = 0.5

x = helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, 64, 64])
y = helper.make_tensor_value_info("heatmaps", TensorProto.FLOAT, [1, 22, H, W])
w = numpy_helper.from_array(np.zeros((22, 3, 8, 8), dtype=np.float32), "w")
c = numpy_helper.from_array(maps, "c")
conv = helper.make_node("Conv", ["image", "w"], ["z"], kernel_shape=[8, 8], strides=[8, 8])
add = helper.make_node("Add", ["z", "c"], ["heatmaps"])
graph = helper.make_graph([conv, add], "synthetic_heatmaps", [x], [y], initializer=[w, c])
model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
model.ir_version = 8
onnx.checker.check_model(model)
onnx.save(model, os.path.join(out_dir, "synthetic_heatmaps.onnx"))
with open(os.path.join(out_dir, "heatmap_fixture.json"), "w") as f:
    json.dump({"generator": "tools/make_heatmap_fixture.py", "input_size": 64, "map_size": 8,
               "peak": 0.9, "peaks_cells": peaks}, f, indent=1)
