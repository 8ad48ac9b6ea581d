"""The planner's parameters (a scenario's ``planner`` section): which program and solver plan
the league problems."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from resilient_tracking.spec import Strict


class RouteSpec(Strict):
    """The route program (docs/calibration.md, "Evade, then come back"): the paper's objective
    plus a cost-to-go along the shortest route around the known keep-out regions to each
    robot's assigned target, with the information model regularised at ``standoff``."""

    speed: float = Field(
        0.8,
        gt=0,
        le=1,
        description=(
            "Speed, as a fraction of the robot's u_max, at which the cost-to-go alone moves a "
            "robot that is far from its goal."
        ),
    )
    reach: float = Field(
        0.7,
        ge=0,
        le=100,
        description="Route length to its goal within which a robot feels no pull.",
        json_schema_extra={"unit": "m"},
    )
    lookahead: float = Field(
        3.0,
        ge=0,
        le=100,
        description="At most this much target motion between a goal and its target's estimate.",
        json_schema_extra={"unit": "s"},
    )
    spread: float = Field(
        0.5,
        ge=0,
        le=100,
        description="Extra route length charged to each further robot assigned to one target.",
        json_schema_extra={"unit": "m"},
    )
    standoff: float = Field(
        0.2,
        gt=0,
        le=10,
        description=(
            "Distance regularisation of the planner's range-bearing information model (the "
            "paper's one-step program uses 0.05)."
        ),
        json_schema_extra={"unit": "m"},
    )
    links: Literal["all", "spanning"] = Field(
        "all",
        description=(
            "Teammates whose link a robot's comm-zone constraint (eq. 7d) protects: all (the "
            "paper's rule) or spanning (its neighbours in the league's shortest spanning tree, "
            "enough to keep the league connected; docs/generalization.md measures both)."
        ),
    )


class SubteamSpec(Strict):
    """Large leagues planned as sub-teams (docs/model.md §9, docs/performance.md): a league of
    more than ``above`` robots solves the league problem for ``size`` robots at a time, with
    ``pinned`` teammates held at their planned step and every other robot's planned
    measurements in the targets' prior; smaller leagues are solved jointly (the paper's
    program), except in a team of more than ``above`` robots, where every league plans on
    windows."""

    above: int = Field(
        20,
        ge=1,
        le=64,
        description=(
            "Leagues of more robots than this are planned as sub-teams; smaller ones jointly, "
            "unless the team has more robots than this. Set 64 to always solve jointly."
        ),
    )
    size: int = Field(8, ge=1, le=64, description="Robots planned together in one sub-team.")
    pinned: int = Field(
        4,
        ge=0,
        le=64,
        description=(
            "Teammates of other sub-teams held at their planned step in each sub-team's "
            "problem (the farthest ones, whose jamming rows of eq. 7d bind first)."
        ),
    )
    targets: int = Field(
        10,
        ge=1,
        le=64,
        description=(
            "Targets in each sub-team's problem: those nearest to its robots (the others' terms "
            "barely depend on them)."
        ),
    )
    sweeps: int = Field(
        1, ge=1, le=10, description="Passes over the sub-teams per step (Gauss-Seidel sweeps)."
    )

    @model_validator(mode="after")
    def _window_fits(self) -> SubteamSpec:
        if self.size + self.pinned > self.above:
            raise ValueError(
                f"size + pinned ({self.size} + {self.pinned}) must not exceed above "
                f"({self.above}): a sub-team's problem must be smaller than the leagues it splits"
            )
        return self


class PlannerSpec(Strict):
    """How league problems are built and solved: the planner program (the paper's one-step
    program or the route program) and the solver (the fast SQP ladder or IPOPT only)."""

    program: Literal["route", "one_step"] = Field(
        "route",
        description=(
            "route: the paper's objective plus a cost-to-go around known zones back to the "
            "targets (docs/calibration.md); one_step: the paper's one-step program (eq. 9)."
        ),
    )
    route: RouteSpec = Field(RouteSpec(), description="Parameters of the route program.")
    solver: Literal["ladder", "ipopt"] = Field(
        "ladder",
        description=(
            "ladder: SQP warm-started from the previous step, then IPOPT warm, IPOPT cold, then "
            "hold position; ipopt: the same without the SQP rung."
        ),
    )
    subteams: SubteamSpec = Field(
        SubteamSpec(), description="How leagues larger than subteams.above robots are planned."
    )
