"""The learned team's network: a robot's view to a velocity, in PyTorch, exportable to ONNX.

``ViewFeatures`` turns a robot's view (the observation of ``resilient_tracking.env``, batched
over robots) into 42 numbers that do not depend on the team's size: its own flags, the three
nearest target estimates and their uncertainty, the direction in which the team's uncertainty
lies, the two nearest known zones and league mates, all relative to the robot. ``Actor`` maps
them to the mean velocity (within the robot's speed bound) and a spread; ``Critic`` to a value.
``export_onnx`` writes features and actor together, so that the file is the whole policy that
``--policy onnx:PATH`` runs (docs/environment.md).
"""

from __future__ import annotations

from pathlib import Path

import torch
from torch import nn

# the view's fields, the inputs of the exported model, in ViewFeatures.forward's order
from resilient_tracking.belief.agent_view import FIELDS

#: Targets, zones and league mates described (nearest first); relative positions are divided
#: by ``SCALE`` metres.
TARGETS, ZONES, MATES = 3, 2, 2
SCALE = 5.0
FEATURES = 4 + 6 * TARGETS + 2 + 6 * ZONES + 3 * MATES
#: A distance standing for "no row here" when fewer rows exist than are described.
FAR = 1e3


def _nearest(gaps: torch.Tensor, present: torch.Tensor, k: int) -> tuple[torch.Tensor, ...]:
    """Indices of the ``k`` nearest present rows of ``gaps`` (..., R, 2), after padding with
    ``k`` absent rows so that ``k`` always exist; returns the padded gaps, presence and
    the indices (..., k)."""
    pad_shape = (*gaps.shape[:-2], k, 2)
    gaps = torch.cat([gaps, torch.full(pad_shape, FAR, dtype=gaps.dtype)], dim=-2)
    present = torch.cat([present, torch.zeros(pad_shape[:-1], dtype=gaps.dtype)], dim=-1)
    distance = torch.linalg.vector_norm(gaps, dim=-1) + (1.0 - present) * FAR
    index = torch.topk(-distance, k, dim=-1).indices
    return gaps, present, index


def _take(rows: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """``rows`` (..., R, F) at ``index`` (..., k) along R."""
    return torch.gather(rows, -2, index.unsqueeze(-1).expand(*index.shape, rows.shape[-1]))


class ViewFeatures(nn.Module):
    """A robot's view (fields batched over robots) as ``FEATURES`` numbers (module
    docstring)."""

    def forward(
        self,
        own: torch.Tensor,
        targets: torch.Tensor,
        target_cov: torch.Tensor,
        teammates: torch.Tensor,
        teammates_mask: torch.Tensor,
        zones: torch.Tensor,
        zones_mask: torch.Tensor,
    ) -> torch.Tensor:
        here = own[..., None, :2]
        u_max = own[..., 2:3].clamp_min(1e-6)
        flags = own[..., 3:7]

        # targets: nearest first, with their velocity (per speed bound) and uncertainty
        spread = torch.log1p(target_cov[..., 0, 0] + target_cov[..., 1, 1])
        gaps = targets[..., :2] - here
        rows = torch.cat([targets[..., 2:] / u_max[..., None], spread[..., None]], dim=-1)
        padded, present, index = _nearest(gaps, torch.ones_like(spread), TARGETS)
        rows = torch.cat([rows, torch.zeros((*rows.shape[:-2], TARGETS, 3))], dim=-2)
        near = torch.cat(
            [
                _take(padded, index) / SCALE,
                _take(rows, index),
                torch.gather(present, -1, index)[..., None],
            ],
            dim=-1,
        ).flatten(-2)

        # where the team's uncertainty lies: unit directions weighted by each target's spread
        distance = torch.linalg.vector_norm(gaps, dim=-1, keepdim=True).clamp_min(1e-3)
        weight = spread / spread.sum(-1, keepdim=True).clamp_min(1e-6)
        pull = (weight[..., None] * gaps / distance).sum(-2)

        # known zones, nearest first already
        zone_rows = torch.cat(
            [
                (zones[..., :2] - here) / SCALE,
                torch.sqrt((zones[..., 2] + zones[..., 4]).clamp_min(0.0))[..., None] / SCALE,
                zones[..., 5:7],
                zones_mask[..., None],
            ],
            dim=-1,
        )
        zone_rows = torch.cat([zone_rows, torch.zeros((*zone_rows.shape[:-2], ZONES, 6))], -2)
        known = zone_rows[..., :ZONES, :].flatten(-2)

        # league mates, nearest first
        padded, present, index = _nearest(teammates - here, teammates_mask, MATES)
        mates = torch.cat(
            [_take(padded, index) / SCALE, torch.gather(present, -1, index)[..., None]], -1
        )
        mates = mates * torch.gather(present, -1, index)[..., None]
        return torch.cat([flags, near, pull, known, mates.flatten(-2)], dim=-1)


def _mlp(width: int, out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Linear(FEATURES, width), nn.Tanh(), nn.Linear(width, width), nn.Tanh(),
        nn.Linear(width, out),
    )  # fmt: skip


class Actor(nn.Module):
    """Features and speed bound to the mean velocity ``u_max · tanh(·)`` and its spread (a
    learned standard deviation per axis, as a fraction of the speed bound)."""

    def __init__(self, width: int = 64):
        super().__init__()
        self.net = _mlp(width, 2)
        self.log_spread = nn.Parameter(torch.full((2,), -1.6))

    def forward(self, features: torch.Tensor, u_max: torch.Tensor) -> tuple[torch.Tensor, ...]:
        loc = u_max * torch.tanh(self.net(features))
        scale = u_max * self.log_spread.exp().expand_as(loc)
        return loc, scale


class Critic(nn.Module):
    """Features to the value of the robot's state."""

    def __init__(self, width: int = 64):
        super().__init__()
        self.net = _mlp(width, 1)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return self.net(features)


class Deployed(nn.Module):
    """View fields to velocities: features then the actor's mean, the whole policy."""

    def __init__(self, actor: Actor):
        super().__init__()
        self.features, self.actor = ViewFeatures(), actor

    def forward(self, *fields: torch.Tensor) -> torch.Tensor:
        own = fields[0]
        return self.actor(self.features(*fields), own[..., 2:3].clamp_min(1e-6))[0]


def export_onnx(
    actor: Actor, path: Path, robots: int = 3, targets: int = 3, zones: int = 8
) -> Path:
    """Write features and actor as one ONNX model at ``path``: inputs named after the view's
    fields, robots, targets and teammates as dynamic axes; output ``velocity`` (robots, 2)."""
    shapes = {
        "own": (robots, 8),
        "targets": (robots, targets, 4),
        "target_cov": (robots, targets, 4, 4),
        "teammates": (robots, robots, 2),
        "teammates_mask": (robots, robots),
        "zones": (robots, zones, 7),
        "zones_mask": (robots, zones),
    }
    dummy = tuple(torch.zeros(shapes[f]) for f in FIELDS)
    axes = {f: {0: "robots"} for f in FIELDS}
    for f in ("targets", "target_cov"):
        axes[f][1] = "targets"
    for f in ("teammates", "teammates_mask"):
        axes[f][1] = "teammates"
    axes["velocity"] = {0: "robots"}
    model = Deployed(actor).eval()
    torch.onnx.export(
        model,
        dummy,
        str(path),
        input_names=list(FIELDS),
        output_names=["velocity"],
        dynamic_axes=axes,
        dynamo=False,
    )
    return path
