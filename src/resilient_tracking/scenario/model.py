"""The whole scenario: every section together, with the cross-field checks pydantic cannot see."""

from __future__ import annotations

import copy
import math
from typing import Annotated, Any

from pydantic import (
    Field,
    PrivateAttr,
    ValidationError,
    ValidatorFunctionWrapHandler,
    field_validator,
    model_validator,
)

from resilient_tracking.belief.settings import BeliefSettings
from resilient_tracking.models.range_bearing import RangeBearingSpec
from resilient_tracking.models.sensor import SENSORS
from resilient_tracking.planning.spec import PlannerSpec
from resilient_tracking.policies.guards.settings import GuardsSpec
from resilient_tracking.scenario.adversarial import Lure
from resilient_tracking.scenario.base import (
    MAX_DT,
    MAX_RECORDED_ROWS,
    MAX_ROBOTS,
    MAX_ROBOTS_X_TARGETS,
    MAX_STEPS,
    MAX_TARGETS,
    MAX_ZONES,
    MIN_DT,
    Strict,
)
from resilient_tracking.scenario.effects import SensingDegrade
from resilient_tracking.scenario.errors import ScenarioError, field_problems
from resilient_tracking.scenario.paths import set_paths
from resilient_tracking.scenario.policies import PolicySpec
from resilient_tracking.scenario.teams import DEFAULT_TEAM, get_team, with_team_settings
from resilient_tracking.scenario.world_specs import (
    Circle,
    Estimator,
    EstimatorSpec,
    MotionSpec,
    RobotSpec,
    Sensor,
    TargetSpec,
    Workspace,
)
from resilient_tracking.scenario.zones import Zone
from resilient_tracking.spec import MAX_LENGTH, MAX_SEED, MAX_SPEED

# ---------------------------------------------------------------------------- scenario


def _motion_chain(motion: MotionSpec, path: str) -> list[tuple[str, MotionSpec]]:
    """A target's motion and the base motions it wraps (an evasive or lure target's ``base``),
    each with its dotted path."""
    chain = [(path, motion)]
    base = getattr(motion, "base", None)
    while isinstance(base, MotionSpec):
        path += ".base"
        chain.append((path, base))
        base = getattr(base, "base", None)
    return chain


def _motion_problems(
    motion: MotionSpec, path: str, start: tuple[float, float], zones: dict[str, int]
) -> list[str]:
    """What is wrong with one motion of a target starting at ``start``, given the zones by
    name: a circle through its own centre or too fast, a lure to a zone no zone is called."""
    if isinstance(motion, Lure) and motion.zone not in zones:
        known = f"zones are named {', '.join(sorted(zones))}" if zones else "no zone has a name"
        return [f"{path}.zone: names no zone of the scenario ({known}) (got {motion.zone!r})"]
    if not isinstance(motion, Circle):
        return []
    radius = math.dist(motion.center, start)
    if radius == 0:
        return [f"{path}.center: equals the start, radius would be 0 (got {list(motion.center)})"]
    if abs(motion.angular_speed) * radius > MAX_SPEED:
        return [
            f"{path}.angular_speed: the speed along the circle of radius {radius:.6g} m would "
            f"be {abs(motion.angular_speed) * radius:.3g} m/s, above {MAX_SPEED:g} m/s "
            f"(got {motion.angular_speed})"
        ]
    return []


def _zone_motion_problems(motion: MotionSpec, path: str, start: tuple[float, float]) -> list[str]:
    """What is wrong with a zone's motion starting at its prior mean ``start``: one that reacts
    to the world (a zone moves on a script), or a circle that cannot be run."""
    if motion.reacts:
        return [
            f"{path}.type: a zone's motion must not react to the world; choose a scripted "
            f"motion such as constant_velocity, waypoints, circle or ncv (got {motion.type!r})"
        ]
    return _motion_problems(motion, path, start, {})


class Scenario(Strict):
    """A whole scenario file: team, targets, zones, policy and planner (docs/scenario-format.md)."""

    name: str = Field("scenario", description="Label used in output folders and plots.")
    team: str = Field(
        DEFAULT_TEAM,
        description=(
            "Named team (rtrack teams lists them): fills in every setting the file leaves"
            " unsaid; the file's own settings override the team's (rtrack run --team"
            " overrides it)."
        ),
    )
    description: str = Field("", description="Free text.")
    seed: int = Field(
        0,
        ge=0,
        le=MAX_SEED,
        description="Episode seed; every random draw comes from its own stream derived from it.",
    )
    #: at most 10 s: beyond it one step moves targets out of any sensor's reach
    dt: float = Field(
        0.1, ge=MIN_DT, le=MAX_DT, description="Time step.", json_schema_extra={"unit": "s"}
    )
    steps: int = Field(
        300,
        ge=1,
        le=MAX_STEPS,
        description="Episode length (duration steps · dt).",
        json_schema_extra={"unit": "steps"},
    )
    workspace: Workspace = Field(Workspace(), description="Box the robots stay in.")
    sensor: Sensor = Field(
        RangeBearingSpec(), description="Sensor of every robot, selected by its type."
    )
    estimator: Estimator = Field(
        EstimatorSpec(),
        description="The robots' estimator, selected by its type: target model and initial "
        "uncertainty.",
    )
    robots: list[RobotSpec] = Field(min_length=1, max_length=MAX_ROBOTS, description="The team.")
    targets: list[TargetSpec] = Field(
        min_length=1, max_length=MAX_TARGETS, description="The targets to track."
    )
    zones: list[Zone] = Field(
        default_factory=list,
        max_length=MAX_ZONES,
        description="Danger zones, initially unknown to the robots, selected by kind.",
    )
    comm_range: Annotated[float, Field(gt=0, le=MAX_LENGTH)] | None = Field(
        None,
        description="Robots link only within this distance; null: unlimited.",
        json_schema_extra={"unit": "m"},
    )
    policy: PolicySpec = Field(
        PolicySpec(), description="The policy the team uses and its parameters."
    )
    guards: GuardsSpec = Field(
        GuardsSpec(),
        description=(
            "Settings of the failure-aware team's guards, the mechanisms beyond the paper, each"
            " under its name with enabled: true or false (docs/model.md §6)."
        ),
    )
    belief: BeliefSettings = Field(
        BeliefSettings(),
        description=(
            "The team's belief: how it reads silent teammates (Alg. 3) and its features beyond"
            " the paper (zone motion, the degradation watch)."
        ),
    )
    planner: PlannerSpec = Field(PlannerSpec(), description="How the league problems are solved.")

    #: the mapping the scenario was validated from, before its team's settings were filled in
    _own: dict[str, Any] | None = PrivateAttr(None)

    @field_validator("team")
    @classmethod
    def _known_team(cls, name: str) -> str:
        try:
            get_team(name)
        except LookupError as err:
            raise ValueError(str(err)) from None
        return name

    @model_validator(mode="wrap")
    @classmethod
    def _fill_in_team(cls, data: Any, handler: ValidatorFunctionWrapHandler) -> Scenario:
        """The team's settings fill in what the mapping leaves unsaid, before validation."""
        if not isinstance(data, dict):
            return handler(data)  # type: ignore[no-any-return]
        try:
            team = get_team(data.get("team", DEFAULT_TEAM))
        except LookupError:
            return handler(data)  # type: ignore[no-any-return]  # the field names the problem
        scenario: Scenario = handler(with_team_settings(data, team))
        scenario._own = copy.deepcopy(data)
        return scenario

    def __eq__(self, other: object) -> bool:
        """Scenarios are equal when their settings are: how each was written (its own mapping,
        before its team filled it in) does not count."""
        if not isinstance(other, Scenario):
            return NotImplemented
        return self.__dict__ == other.__dict__

    def own_data(self) -> dict[str, Any]:
        """A copy of the mapping this scenario says itself, without what its team fills in:
        what :meth:`with_team`, :meth:`with_overrides` and :func:`~.overrides.overridden` change
        (so a scenario changed by them keeps following its team)."""
        own = self._own if self._own is not None else self.model_dump(exclude_unset=True)
        return copy.deepcopy(own)

    def with_team(self, team: str) -> Scenario:
        """This scenario run by the team called ``team``: the team's settings fill in what the
        scenario's own mapping leaves unsaid."""
        data = self.own_data()
        data["team"] = team
        return Scenario.parse(data, f"{self.name} (team {team})")

    def problems(self) -> list[str]:
        """Cross-field problems pydantic cannot see, each naming its field."""
        out: list[str] = []
        ws = self.workspace
        if ws.xmin >= ws.xmax:
            out.append(f"workspace.xmax: must exceed xmin={ws.xmin} (got {ws.xmax})")
        if ws.ymin >= ws.ymax:
            out.append(f"workspace.ymax: must exceed ymin={ws.ymin} (got {ws.ymax})")
        n, m = len(self.robots), len(self.targets)
        if n * m > MAX_ROBOTS_X_TARGETS:
            out.append(
                f"robots: {n} robots × {m} targets exceeds the supported "
                f"{MAX_ROBOTS_X_TARGETS} robot-target pairs (got {n} × {m} = {n * m})"
            )
        if self.steps * (n + m) > MAX_RECORDED_ROWS:
            out.append(
                f"steps: {self.steps} steps × {n + m} robots and targets would record more than "
                f"{MAX_RECORDED_ROWS} rows; split the run (got {self.steps})"
            )
        for i, robot in enumerate(self.robots):
            if not ws.contains(robot.start):
                out.append(f"robots.{i}.start: outside the workspace (got {list(robot.start)})")
        out += self._bias_problems()
        named: dict[str, int] = {}
        for k, zone in enumerate(self.zones):
            if zone.name is None:
                continue
            if zone.name in named:
                out.append(
                    f"zones.{k}.name: already the name of zones.{named[zone.name]}; zone names "
                    f"must be unique (got {zone.name!r})"
                )
            named.setdefault(zone.name, k)
        for k, zone in enumerate(self.zones):
            if zone.motion is not None:
                out += _zone_motion_problems(zone.motion, f"zones.{k}.motion", zone.mu)
        for j, target in enumerate(self.targets):
            if not ws.contains(target.start):
                out.append(f"targets.{j}.start: outside the workspace (got {list(target.start)})")
            for path, motion in _motion_chain(target.motion, f"targets.{j}.motion"):
                out += _motion_problems(motion, path, target.start, named)
        return out

    def _bias_problems(self) -> list[str]:
        """A range bias on a sensor that measures no range (docs/model.md §2)."""
        biased = [
            (k, zone.effect.bias)
            for k, zone in enumerate(self.zones)
            if isinstance(zone.effect, SensingDegrade) and zone.effect.bias != 0
        ]
        if not biased or SENSORS.get(self.sensor.type).RANGE is not None:
            return []
        return [
            f"zones.{k}.effect.bias: the {self.sensor.type} sensor measures no range to bias; "
            f"use noise_factor or dropout (got {bias})"
            for k, bias in biased
        ]

    @classmethod
    def parse(cls, data: Any, source: str = "<scenario>") -> Scenario:
        """Validate a parsed mapping; raise :class:`ScenarioError` naming every bad field."""
        if not isinstance(data, dict):
            raise ScenarioError(source, [f"<root>: must be a mapping (got {type(data).__name__})"])
        try:
            scenario = cls.model_validate(data)
        except ValidationError as err:
            raise ScenarioError(source, field_problems(err, data)) from None
        except RecursionError:
            raise ScenarioError(source, ["<root>: nested too deeply to be a scenario"]) from None
        problems = scenario.problems()
        if problems:
            raise ScenarioError(source, problems)
        return scenario

    def with_overrides(self, **changes: Any) -> Scenario:
        """A validated copy with top-level fields replaced (``seed``, ``steps``, ``policy``…);
        :func:`~.overrides.overridden` changes fields by dotted path."""
        data = self.own_data()
        set_paths(data, changes, f"{self.name} (overridden)")
        return Scenario.parse(data, f"{self.name} (overridden)")
