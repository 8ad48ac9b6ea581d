"""Truth's side of a run's tables: the targets' true positions, the zones' drawn centres, the
events only the world knows (degradations, docs/model.md §2), and the team estimate's error
against truth (``mse``, docs/model.md §8).

Only the place that holds truth feeds it (the episode loop; a node given the targets' poses);
the team never sees these columns.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
import pandas as pd

from resilient_tracking.events import Event
from resilient_tracking.runs.metrics import mse, step_scores
from resilient_tracking.runs.records import ColumnTable
from resilient_tracking.runs.schema import BOUND, EVENTS, TARGETS, TEAM, ZONE_TRACKS, ZONES


class ZoneSpecTruth(Protocol):
    """What the zones table needs of a zone's declaration."""

    @property
    def name(self) -> str | None:
        """The scenario's name for the zone, if it gave one."""

    @property
    def persistence(self) -> str:
        """``temporary`` or ``permanent``."""


class ZoneTruth(Protocol):
    """What the zones table needs of a true zone (a ``world.zones.TrueZone``)."""

    @property
    def id(self) -> int:
        """The zone's id."""

    @property
    def spec(self) -> ZoneSpecTruth:
        """The zone as the scenario declares it."""

    @property
    def kind(self) -> str:
        """``sensing`` or ``comm``."""

    @property
    def mu(self) -> np.ndarray:
        """Prior mean of the centre (2,)."""

    @property
    def sigma(self) -> np.ndarray:
        """Prior covariance of the centre (2, 2)."""

    @property
    def size(self) -> float:
        """Sensing: the radius; comm: the jamming strength."""

    @property
    def center(self) -> np.ndarray:
        """The drawn true centre (2,)."""


def zone_table(zones: Sequence[ZoneTruth]) -> pd.DataFrame:
    """The zones table: one row per true zone (declared columns, all ``object``, if none)."""
    if not zones:
        return ZONES.empty_frame()
    table = ColumnTable(ZONES.numpy_dtypes(), len(zones))
    for z in zones:
        table.append_row(
            zone=z.id,
            name=z.spec.name or f"{'M' if '+' in z.kind else z.kind[0].upper()}{z.id}",
            kind=z.kind,
            persistence=z.spec.persistence,
            mu_x=z.mu[0],
            mu_y=z.mu[1],
            sigma_xx=z.sigma[0, 0],
            sigma_xy=z.sigma[0, 1],
            sigma_yy=z.sigma[1, 1],
            size=z.size,
            true_x=z.center[0],
            true_y=z.center[1],
        )
    return table.frame()


def zone_tracks(zones: Sequence[ZoneTruth], steps: int) -> pd.DataFrame:
    """The zone_tracks table: where each moving zone (one with a ``track``) was at each of the
    first ``steps`` steps, zone by zone; no rows when no zone moves."""
    tracks = [(z.id, [r for r in getattr(z, "track", ()) if r[0] < steps]) for z in zones]
    table = ColumnTable(ZONE_TRACKS.numpy_dtypes(), max(1, sum(len(t) for _, t in tracks)))
    for zone, rows in tracks:
        if rows:
            step, mu_x, mu_y, true_x, true_y = (np.array(c) for c in zip(*rows, strict=True))
            table.append(
                len(rows), step=step, zone=zone, mu_x=mu_x, mu_y=mu_y, true_x=true_x, true_y=true_y
            )
    return table.frame()


class TruthRecorder:
    """Rows of truth's columns: the targets' true positions and the team estimate's error
    against them."""

    def __init__(self, n_targets: int, steps: int, zones: Sequence[ZoneTruth] = ()):
        self.team = ColumnTable(TEAM.numpy_dtypes("truth"), steps)
        self.targets = ColumnTable(TARGETS.numpy_dtypes("truth"), steps * n_targets)
        self.zones = zone_table(zones)
        self.events = ColumnTable(EVENTS.numpy_dtypes())
        self.bound = ColumnTable(BOUND.numpy_dtypes())
        self._zones = zones

    def step(
        self,
        step: int,
        truth: np.ndarray,
        estimate: np.ndarray,
        cov: np.ndarray,
        bound: float | None = None,
    ) -> None:
        """Record step ``step``: true positions ``truth`` (N, 2), the team's estimated positions
        ``estimate`` (N, 2) of the same step with their covariances ``cov`` (N, 2, 2), and the
        step's bound (:mod:`~resilient_tracking.runs.bound`) when one is computed."""
        nll, nees = step_scores(estimate, truth, cov)
        self.team.append_row(step=step, mse=mse(estimate, truth), nll=nll, nees=nees)
        if bound is not None:
            self.bound.append_row(step=step, bound=bound)
        n = len(truth)
        self.targets.append(n, step=step, target=np.arange(n), x=truth[:, 0], y=truth[:, 1])

    def record_events(self, events: Sequence[Event]) -> None:
        """Record truth's own events (rows of the events table the team never sees)."""
        for e in events:
            self.events.append_row(**{name: getattr(e, name) for name in EVENTS.names})

    def tables(self) -> dict[str, pd.DataFrame]:
        """Truth's part of the team, targets and events tables, the zones, zone_tracks and
        bound tables."""
        return {
            "team": self.team.frame(),
            "targets": self.targets.frame(),
            "events": self.events.frame() if len(self.events) else EVENTS.empty_frame(),
            "zones": self.zones,
            "zone_tracks": zone_tracks(self._zones, len(self.team)),
            "bound": self.bound.frame() if len(self.bound) else BOUND.empty_frame(),
        }
