"""ONNX models for the tests, built with onnx's helpers (the test extra has onnx)."""

from __future__ import annotations

import atexit
import shutil
import tempfile
from functools import cache
from pathlib import Path

import numpy as np

GAIN = 2.0


def pursue(view: dict[str, np.ndarray]) -> np.ndarray:
    """The pursuer in NumPy: ``GAIN`` × (mean target position − own position), float32."""
    aim = view["targets"][..., :2].mean(axis=-2, dtype=np.float32)
    return (np.float32(GAIN) * (aim - view["own"][..., :2])).astype(np.float32)


def pursuer_model(
    path: Path,
    batch: int | str = "robots",
    n_targets: int | str = "targets",
    input_name: str = "targets",
    divide_by_zero: bool = False,
) -> Path:
    """Write the pursuer as ONNX: inputs ``own`` (batch, 8) and ``targets`` (batch, N, 4),
    output ``velocity`` (batch, 2); ``divide_by_zero``: its output is 0/0 (NaN)."""
    from onnx import TensorProto, checker, helper, save

    const = [
        helper.make_tensor("zero", TensorProto.INT64, [1], [0]),
        helper.make_tensor("two", TensorProto.INT64, [1], [2]),
        helper.make_tensor("last", TensorProto.INT64, [1], [-1]),
        helper.make_tensor("gain", TensorProto.FLOAT, [], [GAIN]),
    ]
    nodes = [
        helper.make_node("Slice", [input_name, "zero", "two", "last"], ["xy"]),
        helper.make_node("ReduceMean", ["xy"], ["aim"], axes=[1], keepdims=0),
        helper.make_node("Slice", ["own", "zero", "two", "last"], ["here"]),
        helper.make_node("Sub", ["aim", "here"], ["gap"]),
        helper.make_node("Mul", ["gap", "gain"], ["step"]),
    ]
    if divide_by_zero:
        nodes.append(helper.make_node("Sub", ["step", "step"], ["nothing"]))
        nodes.append(helper.make_node("Div", ["nothing", "nothing"], ["velocity"]))
    else:
        nodes.append(helper.make_node("Identity", ["step"], ["velocity"]))
    graph = helper.make_graph(
        nodes,
        "pursuer",
        [
            helper.make_tensor_value_info("own", TensorProto.FLOAT, [batch, 8]),
            helper.make_tensor_value_info(input_name, TensorProto.FLOAT, [batch, n_targets, 4]),
        ],
        [helper.make_tensor_value_info("velocity", TensorProto.FLOAT, [batch, 2])],
        initializer=const,
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    checker.check_model(model)
    save(model, str(path))
    return path


@cache
def shared_pursuer() -> Path:
    """The pursuer for any team (its robot and target axes free), written once per process."""
    folder = Path(tempfile.mkdtemp(prefix="rtrack-onnx-"))
    atexit.register(shutil.rmtree, folder, True)
    return pursuer_model(folder / "pursuer.onnx")
