"""Events worth a row in ``events.parquet``: attacks, recoveries, learning, merges, fallbacks.

An :class:`Event` is a typed record: besides its name it carries the facts a reader needs
(failure kind, zone, persistence, cause, how a zone was learned, which fallback a plan took)
as fields, which are the columns of the events table
(:data:`resilient_tracking.runs.schema.TABLES`). Each kind of event is made by its own
constructor below, the one place where its human-readable ``detail`` is written; readers use
the fields, never the text.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

#: ``robot`` value for events that concern a league or the whole team.
TEAM = -1
#: ``zone`` value for events that concern no known zone.
NO_ZONE = -1

EventName = Literal[
    "attack",
    "recover",
    "covariance_repaired",
    "league_merge",
    "league_split",
    "zone_learned",
    "zone_suspected",
    "zone_inferred",
    "target_suspected",
    "degradation_detected",
    "solver_fallback",
    "invalid_decision",
    "pose_lost",
    "pose_regained",
    "degraded",
    "degradation_ended",
]
#: Every event name, in the order of :data:`EventName`.
EVENT_NAMES: tuple[EventName, ...] = get_args(EventName)
#: Events only the world writes (the truth side of the events table): the team never makes
#: nor sees them, so a silent degradation stays silent to it.
TRUTH_EVENTS: tuple[EventName, ...] = ("degraded", "degradation_ended")


@dataclass(frozen=True)
class Event:
    """One row of ``events.parquet``; fields that do not apply keep their empty default."""

    step: int
    #: the robot concerned, or :data:`TEAM`
    robot: int
    event: EventName
    #: one line for people, written by the constructor of the event's kind
    detail: str = ""
    #: failure kind ``sensing``/``comm`` of the attack, recovery or zone; empty otherwise
    kind: str = ""
    #: id of the zone that attacked or was learned, :data:`NO_ZONE` when none is known
    zone: int = NO_ZONE
    #: ``temporary``/``permanent`` (attack: of the failure; zone_learned: as believed, also
    #: ``unknown``); empty otherwise
    persistence: str = ""
    #: why an attack happened: ``hazard`` (the zone's draw), ``jamming`` (links cut) or
    #: ``degradation`` (an announced degradation) or ``spread`` (passed on by a teammate's
    #: compromised radio); a degradation: ``announced`` or ``silent``; what
    #: was wrong with an invalid decision (``not_finite``, ``out_of_bounds``, ``shape``…); why
    #: a target became suspect (``linger``, ``zone``)
    cause: str = ""
    #: how a zone became known: ``attack``, ``broadcast``, ``circle``, ``silence``,
    #: ``degradation`` (a robot found its sensor degraded)
    source: str = ""
    #: the rung a plan fell back to (``safe`` or a simpler program)
    fallback: str = ""
    #: what the safe action did for the robot: ``escape`` or ``hold``; ``hold`` for a robot
    #: that is held (an invalid decision, a lost pose)
    action: str = ""
    #: the planner's status that led to a fallback
    status: str = ""

    @classmethod
    def attack(
        cls, step: int, robot: int, kind: str, zone: int, persistence: str, cause: str
    ) -> Event:
        """A robot lost its sensor or radio to ``zone``."""
        detail = f"{kind} zone{zone} {persistence} ({cause})"
        return cls(
            step,
            robot,
            "attack",
            detail,
            kind=kind,
            zone=zone,
            persistence=persistence,
            cause=cause,
        )

    @classmethod
    def recover(cls, step: int, robot: int, kind: str) -> Event:
        """A robot's temporary failure of ``kind`` ended."""
        return cls(step, robot, "recover", kind, kind=kind)

    @classmethod
    def covariance_repaired(cls, step: int, league: Sequence[int], description: str) -> Event:
        """A league's covariance was made symmetric positive definite again."""
        return cls(step, TEAM, "covariance_repaired", f"league {list(league)} {description}")

    @classmethod
    def league_merge(
        cls,
        step: int,
        members: Sequence[int],
        league: Sequence[int],
        lambdas: Sequence[float] | np.ndarray,
    ) -> Event:
        """Robots ``members`` joined ``league``; ``lambdas`` are the fusion weights (eq. 10)."""
        weights = np.round(np.asarray(lambdas), 3).tolist()
        detail = f"robots {list(members)} joined {list(league)}; lambda={weights}"
        return cls(step, TEAM, "league_merge", detail)

    @classmethod
    def league_split(cls, step: int, league: Sequence[int]) -> Event:
        """``league`` split off the league it belonged to."""
        return cls(step, TEAM, "league_split", f"league {list(league)} split off")

    @classmethod
    def zone_learned(
        cls,
        step: int,
        robot: int,
        key: str,
        kind: str,
        source: str,
        zone: int | None,
        persistence: str,
    ) -> Event:
        """``robot`` learned the zone estimate ``key`` through ``source``."""
        return cls(
            step,
            robot,
            "zone_learned",
            f"{key} {kind} via {source}",
            kind=kind,
            zone=NO_ZONE if zone is None else zone,
            persistence=persistence,
            source=source,
        )

    @classmethod
    def zone_suspected(cls, step: int, robot: int, x: float, y: float) -> Event:
        """``robot`` fell silent at ``(x, y)``: a provisional comm zone there."""
        return cls(
            step, robot, "zone_suspected", f"at ({x:.3f}, {y:.3f})", kind="comm", source="silence"
        )

    @classmethod
    def zone_inferred(
        cls,
        step: int,
        robot: int,
        center: Sequence[float] | np.ndarray,
        radius: float,
        residual: float,
        arc: float,
        samples: int,
    ) -> Event:
        """A comm zone was fitted to the circle ``robot`` flies (Alg. 4)."""
        detail = (
            f"center=({center[0]:.3f}, {center[1]:.3f}) radius={radius:.3f}"
            f" residual={residual:.4f} arc={arc:.2f} n={samples}"
        )
        return cls(step, robot, "zone_inferred", detail, kind="comm", source="circle")

    @classmethod
    def target_suspected(
        cls, step: int, robot: int, target: int, cause: str, x: float, y: float
    ) -> Event:
        """``robot``'s league suspects target ``target`` (estimated at ``(x, y)``) of luring it
        into danger; ``cause``: ``surge`` (it sped up off a steady course), ``linger`` (it
        stopped after moving) or ``zone`` (it stands at a known zone's keep-out disc)."""
        detail = f"target {target} ({cause}) at ({x:.3f}, {y:.3f})"
        return cls(step, robot, "target_suspected", detail, cause=cause)

    @classmethod
    def degradation_detected(
        cls, step: int, robot: int, factor: float, statistic: float, x: float, y: float
    ) -> Event:
        """``robot``'s measurements disagree with its league's estimate: its sensor looks
        degraded (estimated noise factor ``factor``, CUSUM ``statistic``), found at ``(x, y)``."""
        detail = f"noise factor {factor:.2f} (CUSUM {statistic:.1f}) at ({x:.3f}, {y:.3f})"
        return cls(
            step, robot, "degradation_detected", detail, kind="sensing", source="degradation"
        )

    @classmethod
    def solver_fallback(
        cls, step: int, robot: int, fallback: str, status: str, action: str = ""
    ) -> Event:
        """``robot``'s plan fell back to ``fallback`` (with the safe ``action``, if any)."""
        detail = f"safe ({action}): {status}" if action else f"{fallback}: {status}"
        return cls(
            step, robot, "solver_fallback", detail, fallback=fallback, action=action, status=status
        )

    @classmethod
    def invalid_decision(
        cls, step: int, robot: int, policy: str, problem: str, message: str
    ) -> Event:
        """``policy`` decided something ``robot`` cannot do (``problem``: ``not_finite``,
        ``out_of_bounds``, ``shape``, ``type`` or ``modes``); the robot held its position."""
        detail = f"policy {policy}: {message}"
        return cls(step, robot, "invalid_decision", detail, cause=problem, action="hold")

    @classmethod
    def pose_lost(cls, step: int, robot: int, silent: float, timeout: float) -> Event:
        """On robots: no pose of ``robot`` for ``silent`` seconds, over the pose timeout
        ``timeout``; it holds its last seen position while the team plans for the others."""
        detail = f"no pose for {silent:.2f} s (pose timeout {timeout:g} s): holds position"
        return cls(step, robot, "pose_lost", detail, action="hold")

    @classmethod
    def pose_regained(cls, step: int, robot: int) -> Event:
        """On robots: poses of ``robot`` arrive again after a ``pose_lost``; it is planned for
        again."""
        return cls(step, robot, "pose_regained", "poses arrive again")

    @classmethod
    def degraded(
        cls, step: int, robot: int, kind: str, zone: int, persistence: str, announced: bool
    ) -> Event:
        """Truth: ``zone`` degraded ``robot``'s sensor or radio (``announced`` or silent)."""
        cause = "announced" if announced else "silent"
        detail = f"{kind} zone{zone} {persistence} ({cause})"
        return cls(
            step,
            robot,
            "degraded",
            detail,
            kind=kind,
            zone=zone,
            persistence=persistence,
            cause=cause,
        )

    @classmethod
    def degradation_ended(cls, step: int, robot: int, kind: str, zone: int) -> Event:
        """Truth: ``robot``'s temporary degradation of ``kind`` by ``zone`` ended."""
        return cls(step, robot, "degradation_ended", f"{kind} zone{zone}", kind=kind, zone=zone)
