"""Scenario files: schema, loading and validation with errors that name the field.

A scenario is a YAML mapping validated by pydantic models, one module per part of the file:

- :mod:`~.base`: the strict base model, bounded number types, size limits;
- :mod:`~.world_specs`: workspace, robots, targets and their motions, sensor, estimator;
- :mod:`~.adversarial`: target motions that react to the world (evasive, lure);
- :mod:`~.zones`: danger zones and their hazard models;
- :mod:`~.policies`: the ``policy`` section; the ``planner`` section is the planner's own
  :mod:`~resilient_tracking.planning.spec`;
- :mod:`~.model`: the whole :class:`Scenario` with its cross-field checks;
- :mod:`~.loading`: ``load_scenario`` returns a :class:`Scenario` or raises
  :class:`ScenarioError` listing every problem as ``field.path: message (got value)``;
- :mod:`~.overrides`: changing fields by dotted path (``{"zones.0.hazard.kappa": 2.0}``).

The format is documented in ``docs/scenario-format.md``; everything is importable from here.
"""

from __future__ import annotations

from resilient_tracking.models.range_bearing import RangeBearingSpec
from resilient_tracking.models.sensor import SensorChannel, SensorSpec
from resilient_tracking.planning.spec import (
    PlannerSpec,
    RouteSpec,
)
from resilient_tracking.scenario.adversarial import Evasive, Lure
from resilient_tracking.scenario.base import (
    MAX_COORDINATE,
    MAX_DT,
    MAX_RECORDED_ROWS,
    MAX_ROBOTS,
    MAX_ROBOTS_X_TARGETS,
    MAX_STEPS,
    MAX_TARGETS,
    MAX_VARIANCE,
    MAX_ZONES,
    MIN_COVARIANCE_RATIO,
    MIN_DT,
    MIN_VARIANCE,
    Coordinate,
    Matrix2,
    Number,
    PositiveFloat,
    Row2,
    Strict,
    Vec2,
)
from resilient_tracking.scenario.loading import (
    ScenarioError,
    load_scenario,
    parse_scenario,
)
from resilient_tracking.scenario.model import (
    Scenario,
)
from resilient_tracking.scenario.overrides import apply_overrides, overridden
from resilient_tracking.scenario.policies import PolicySpec
from resilient_tracking.scenario.world_specs import (
    AdaptiveEstimatorSpec,
    Circle,
    ConstantVelocity,
    EstimatorSpec,
    ImmEstimatorSpec,
    MotionSpec,
    NoisyConstantVelocity,
    RobotSpec,
    Sensor,
    TargetMotion,
    TargetSpec,
    Waypoints,
    Workspace,
)
from resilient_tracking.scenario.zones import (
    CommZone,
    DiskHazard,
    GaussianHazard,
    Hazard,
    HazardSpec,
    MultimodalZone,
    SensingZone,
    SpreadSpec,
    Zone,
    ZoneBase,
    zone_tag,
)

__all__ = [
    "MAX_COORDINATE",
    "MAX_VARIANCE",
    "MIN_COVARIANCE_RATIO",
    "MIN_VARIANCE",
    "MAX_ROBOTS",
    "MAX_TARGETS",
    "MAX_ROBOTS_X_TARGETS",
    "MAX_ZONES",
    "MAX_STEPS",
    "MAX_DT",
    "MIN_DT",
    "MAX_RECORDED_ROWS",
    "Number",
    "Coordinate",
    "Vec2",
    "Row2",
    "Matrix2",
    "PositiveFloat",
    "Strict",
    "Workspace",
    "RobotSpec",
    "MotionSpec",
    "ConstantVelocity",
    "Waypoints",
    "Circle",
    "NoisyConstantVelocity",
    "Evasive",
    "Lure",
    "TargetMotion",
    "TargetSpec",
    "SensorChannel",
    "SensorSpec",
    "RangeBearingSpec",
    "Sensor",
    "EstimatorSpec",
    "ImmEstimatorSpec",
    "AdaptiveEstimatorSpec",
    "HazardSpec",
    "GaussianHazard",
    "DiskHazard",
    "Hazard",
    "ZoneBase",
    "SensingZone",
    "CommZone",
    "MultimodalZone",
    "SpreadSpec",
    "Zone",
    "zone_tag",
    "PolicySpec",
    "RouteSpec",
    "PlannerSpec",
    "Scenario",
    "ScenarioError",
    "parse_scenario",
    "load_scenario",
    "apply_overrides",
    "overridden",
]
