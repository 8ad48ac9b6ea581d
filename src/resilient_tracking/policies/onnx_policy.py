"""A trained team saved as ONNX, run by onnxruntime: ``--policy onnx:team.onnx``.

The model maps robots' views (:mod:`resilient_tracking.belief.agent_view`, the observation of
the learning environments) to their velocities. Its inputs are named after the fields of a view
(``own``, ``targets``, ``target_cov``, ``teammates``, ``teammates_mask``, ``zones``,
``zones_mask``; any of them), each ``float32`` with a leading axis for the robots; its first
output is the velocities, ``(robots, 2)``. Scaling and flattening belong inside the graph, so
the file is the whole policy. All robots go through in one call, or one at a time when the
model's leading axis is fixed at 1.

The policy is named in a scenario as ``policy: {name: "onnx:team.onnx"}`` (or ``name: onnx``
with ``policy.params.model``); a relative path is taken from the working directory. A name with
no folder and no suffix that is no file there is a model shipped with the package
(:data:`SHIPPED`): ``onnx:learned-team`` is the team trained by ``examples/learned_team``.
Needs the ``onnx`` extra (``pip install "resilient-tracking[onnx]"``).

Before the first tick the model is checked against the team: the file opens, every input is a
field of a view with that field's shape for this team, and on a view of zeros the output has
shape ``(robots, 2)`` and is finite. Each mismatch is a ``ValueError`` naming the file and what
does not match. Velocities are clipped to the robots' bounds like any learned policy's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from resilient_tracking.belief.agent_view import FIELDS, MAX_ZONES, ViewShape
from resilient_tracking.policies.base import register_policy
from resilient_tracking.policies.learned import CallablePolicy, ViewFunction
from resilient_tracking.spec import Strict


class OnnxParams(Strict):
    """Which model decides, and the size of the views it is given."""

    model: str = Field(
        "",
        description="Path of the ONNX model (relative paths from the working directory).",
    )
    max_zones: int = Field(
        MAX_ZONES, ge=0, le=64, description="Rows of known zones in each view (the nearest)."
    )


#: The folder of the models shipped with the package, each ``NAME.onnx`` (``onnx:NAME``).
SHIPPED = Path(__file__).with_name("models")


def model_path(model: str) -> Path:
    """The file of ``model``: a path, or the name of a shipped model (module docstring)."""
    path = Path(model)
    if not path.exists() and path.name == model and not path.suffix:
        shipped = SHIPPED / f"{model}.onnx"
        if shipped.is_file():
            return shipped
    return path


@register_policy("onnx")
class OnnxPolicy(CallablePolicy):
    """Each robot moves as the ONNX model decides from its own view (module docstring)."""

    name: ClassVar[str] = "onnx"
    Params = OnnxParams  # type: ignore[assignment]
    params: OnnxParams  # type: ignore[assignment]
    argument: ClassVar[str | None] = "model"
    mode: ClassVar[str] = "learned"

    @classmethod
    def files_read(cls, params: Any) -> list[Path]:
        """The model file: its weights decide the velocities."""
        return [model_path(params.model)] if params.model else []

    def make_function(self) -> ViewFunction:
        """Open the model and check its inputs and outputs as far as the team's robots and
        zone rows tell; the function runs it on one robot's view."""
        path = model_path(self.params.model)
        self.where = f"policy onnx: model {self.params.model!r}"
        if not self.params.model:
            raise ValueError("policy onnx: give the model file as onnx:PATH or params.model")
        if not path.is_file():
            shipped = ", ".join(sorted(m.stem for m in SHIPPED.glob("*.onnx"))) or "none"
            raise ValueError(f"{self.where}: no such file (models shipped: {shipped})")
        try:
            import onnxruntime
        except ImportError:
            raise ValueError(
                f"{self.where}: onnxruntime is not installed "
                '(pip install "resilient-tracking[onnx]")'
            ) from None
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = 1  # one robot team per process; sweeps run in parallel
        options.inter_op_num_threads = 1
        try:
            self.runtime = onnxruntime.InferenceSession(
                str(path), options, providers=["CPUExecutionProvider"]
            )
        except Exception as err:  # onnxruntime's errors name no field; say what it is
            raise ValueError(f"{self.where}: not a model onnxruntime can run ({err})") from None
        self.inputs = {i.name: list(i.shape) for i in self.runtime.get_inputs()}
        kinds = {i.name: i.type for i in self.runtime.get_inputs()}
        for name in self.inputs:
            if name not in FIELDS:
                raise ValueError(
                    f"{self.where}: input {name!r} is not a field of a robot's view "
                    f"({', '.join(FIELDS)})"
                )
            if kinds[name] != "tensor(float)":
                raise ValueError(f"{self.where}: input {name!r} is {kinds[name]}, not float32")
        outputs = self.runtime.get_outputs()
        if not outputs:
            raise ValueError(f"{self.where}: the model has no output")
        self.output = outputs[0].name
        # a leading axis fixed at 1 takes one robot at a time
        self.one_at_a_time = any(shape[:1] == [1] for shape in self.inputs.values())
        return self._one_view

    def check_targets(self, n_targets: int) -> None:
        """Every input has its field's shape for this team, and on a view of zeros the output
        is ``(robots, 2)`` and finite (module docstring)."""
        m = self.config.n_robots
        shapes = ViewShape(m, n_targets, self.params.max_zones).shapes()
        batch = 1 if self.one_at_a_time else m
        for name, shape in self.inputs.items():
            want = [batch, *shapes[name]]
            if len(shape) != len(want) or any(
                isinstance(got, int) and got != need for got, need in zip(shape, want, strict=True)
            ):
                raise ValueError(
                    f"{self.where}: input {name!r} has shape {_shown(shape)}; this team's views "
                    f"give {tuple(want)} ({m} robots, {n_targets} targets, "
                    f"{self.params.max_zones} zone rows)"
                )
        views = {name: np.zeros((m, *shape), dtype=np.float32) for name, shape in shapes.items()}
        try:
            out = self.velocities(views)
        except Exception as err:  # a shape it refuses is said as onnxruntime words it
            if isinstance(err, ValueError):
                raise
            raise ValueError(f"{self.where}: failed on a view of zeros ({err})") from None
        if not np.all(np.isfinite(out)):
            raise ValueError(
                f"{self.where}: gives velocities that are not finite on a view of zeros"
            )

    def velocities(self, views: dict[str, np.ndarray]) -> np.ndarray:
        """``(M, 2)`` velocities: the model on every robot's view at once (one at a time when
        its leading axis is fixed at 1)."""
        m = len(views["own"])
        if self.one_at_a_time:
            return np.vstack(
                [self._run({k: v[i : i + 1] for k, v in views.items()}, 1) for i in range(m)]
            )
        return self._run(views, m)

    def _one_view(self, view: dict[str, np.ndarray]) -> np.ndarray:
        return self._run({k: v[None] for k, v in view.items()}, 1)[0]

    def _run(self, views: dict[str, np.ndarray], rows: int) -> np.ndarray:
        """The model's first output for ``rows`` views, as ``(rows, 2)`` floats."""
        feed = {name: np.ascontiguousarray(views[name], dtype=np.float32) for name in self.inputs}
        out = np.asarray(self.runtime.run([self.output], feed)[0], dtype=float)
        if out.shape != (rows, 2):
            raise ValueError(
                f"{self.where}: output {self.output!r} has shape {out.shape}, not ({rows}, 2) "
                "(one velocity per robot)"
            )
        return out

    def __getstate__(self) -> dict[str, Any]:
        """A copy reopens the model (onnxruntime cannot copy a loaded model)."""
        state = self.__dict__.copy()
        del state["runtime"], state["function"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.function = self.make_function()


def _shown(shape: list[Any]) -> str:
    """An ONNX input shape, its free axes by name (``?`` when unnamed)."""
    return "(" + ", ".join(str(d) if d not in (None, "") else "?" for d in shape) + ")"
