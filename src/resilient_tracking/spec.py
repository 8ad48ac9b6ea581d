"""The base of every parameter model: strict pydantic models and bounded number types.

Each component (a policy, the planner, a sensor, a hazard model, a target motion) declares its
own parameters as a model built on :class:`Strict`; the scenario schema
(:mod:`resilient_tracking.scenario`) assembles them. Nothing here knows any component.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field
from pydantic import Strict as StrictMode

#: Largest magnitude (m) of a coordinate; beyond it, products of positions overflow.
MAX_COORDINATE = 1e6
#: Largest length (m) of a range, radius, clearance or tolerance: beyond the diagonal (2.8e6 m)
#: of the largest workspace, where it no longer changes anything.
MAX_LENGTH = 1e7
#: Largest speed (m/s) of a robot or target, per component or along a path: 1 km/s, three
#: times the speed of sound, beyond any vehicle this tracker follows.
MAX_SPEED = 1e3
#: Largest turn rate (rad/s) of a target: just under half a turn per step at the shortest step
#: (π per 1 ms is 3142 rad/s); a faster turn aliases to a slower one.
MAX_TURN_RATE = 3000.0
#: Largest standard deviation (m/s²) of an acceleration: 1000 m/s², about 100 g.
MAX_ACCEL = 1e3
#: Largest magnitude (m²) of a covariance entry: a 1e6 m standard deviation, the size of the
#: largest workspace.
MAX_VARIANCE = 1e12
#: Largest standard deviation (m) of a position: its variance is :data:`MAX_VARIANCE`.
MAX_POSITION_STD = 1e6
#: Smallest eigenvalue (m²) of a covariance: below it the Gaussian density's normaliser
#: 1/(2π√det Σ) overflows (det Σ underflows to 0 near 1e-300), so the hazard and the risk maps
#: would be NaN. 1e-6 m² is a 1 mm standard deviation, far below any sensor's.
MIN_VARIANCE = 1e-6
#: Bounds on a sensor channel's inverse variance at distance 0 (m⁻² or rad⁻²): at most a
#: 0.1 mm (0.1 mrad) standard deviation; at least 1e-12, a 1e6 m one, a sensor that tells
#: nothing. Below it the noise variance ``exp(shape·d)/peak`` overflows.
MAX_INFORMATION = 1e8
MIN_INFORMATION = 1e-12
#: Largest decay rate (1/m) of a sensor's information with distance: e-fold every centimetre.
MAX_DECAY = 100.0
#: Bounds on a weight or penalty of a planner's cost: the shipped ones are 0.05 to 4000; a ratio
#: beyond 1e12 between two terms is below the solvers' tolerance, and larger weights make every
#: solve fail.
MAX_WEIGHT = 1e6
MIN_WEIGHT = 1e-6
#: Largest hazard intensity κ (m²): the area of the largest workspace (2e6 m)² is 4e12 m²; at
#: 1e12 an attack is all but certain wherever the zone's density is not negligible.
MAX_INTENSITY = 1e12
#: Largest rate (Hz, 1/s) of an event (an activation, an attack): one per shortest step (1 ms).
MAX_RATE = 1e3
#: Largest duration (s): the longest episode, 100 000 steps of 10 s.
MAX_DURATION = 1e6
#: Largest count of steps in a parameter (a cool-down, a window): the longest episode.
MAX_STEP_COUNT = 100_000
#: Largest episode seed: the largest signed 64-bit integer, so every reader of a manifest holds it
#: exactly.
MAX_SEED = 2**63 - 1
#: Largest ratio of lengths (a jammer strength δ2) and of a Mahalanobis distance: at 1e4 a jammer
#: cuts every link and a region holds the whole workspace.
MAX_RATIO = 1e4
#: Most linearisations of one measurement update (the iterated EKF converges in a few).
MAX_UPDATE_ITERATIONS = 100
#: Most process-noise levels of an adaptive estimator (each is one more filter per target).
MAX_NOISE_LEVELS = 15

#: The limits above as the scenario reference lists them: name, value, unit, why.
LIMITS: tuple[tuple[str, float, str, str], ...] = (
    ("MAX_COORDINATE", MAX_COORDINATE, "m", "coordinates: products of positions stay finite"),
    ("MAX_LENGTH", MAX_LENGTH, "m", "ranges, radii, clearances: beyond any workspace's diagonal"),
    ("MAX_SPEED", MAX_SPEED, "m/s", "speeds and velocity components: three times sound's"),
    ("MAX_TURN_RATE", MAX_TURN_RATE, "rad/s", "turn rates: under half a turn per 1 ms step"),
    ("MAX_ACCEL", MAX_ACCEL, "m/s²", "acceleration noise: about 100 g"),
    ("MAX_VARIANCE", MAX_VARIANCE, "m²", "covariance entries: a 1e6 m standard deviation"),
    ("MAX_POSITION_STD", MAX_POSITION_STD, "m", "position spreads: variance MAX_VARIANCE"),
    ("MIN_VARIANCE", MIN_VARIANCE, "m²", "covariance eigenvalues: 1 mm; the density stays finite"),
    ("MAX_INFORMATION", MAX_INFORMATION, "1/variance", "sensor peaks: a 0.1 mm or 0.1 mrad noise"),
    ("MIN_INFORMATION", MIN_INFORMATION, "1/variance", "sensor peaks: noise variance stays finite"),
    ("MAX_DECAY", MAX_DECAY, "1/m", "sensor decay: e-fold per centimetre"),
    (
        "MAX_WEIGHT",
        MAX_WEIGHT,
        "–",
        "cost weights: the shipped ones are 0.05-4000",
    ),
    ("MIN_WEIGHT", MIN_WEIGHT, "–", "positive cost weights: ratios stay above solver tolerance"),
    ("MAX_INTENSITY", MAX_INTENSITY, "m²", "hazard intensity κ: an attack is all but certain"),
    ("MAX_RATE", MAX_RATE, "1/s", "activation and hazard rates: one per 1 ms step"),
    ("MAX_DURATION", MAX_DURATION, "s", "durations: the longest episode (100 000 × 10 s)"),
    ("MAX_STEP_COUNT", MAX_STEP_COUNT, "steps", "step counts: the longest episode"),
    ("MAX_RATIO", MAX_RATIO, "–", "jammer strength δ2, Mahalanobis sizes: all links, all space"),
    ("MAX_SEED", MAX_SEED, "–", "seeds: the largest signed 64-bit integer"),
    ("MAX_UPDATE_ITERATIONS", MAX_UPDATE_ITERATIONS, "–", "EKF linearisations per update"),
    ("MAX_NOISE_LEVELS", MAX_NOISE_LEVELS, "–", "process-noise levels: one filter per level"),
)

#: A number inside a list: strict (an int or a float, never a bool or a string) even where the
#: list itself is lax (``StrictMode(False)`` lets a YAML list stand for a tuple).
Number = Annotated[float, StrictMode()]
#: A coordinate: a strict number of bounded size.
Coordinate = Annotated[float, StrictMode(), Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
Vec2 = Annotated[tuple[Coordinate, Coordinate], StrictMode(False)]
#: A velocity component (m/s): a strict number within ±:data:`MAX_SPEED`.
Speed = Annotated[float, StrictMode(), Field(ge=-MAX_SPEED, le=MAX_SPEED)]
Velocity2 = Annotated[tuple[Speed, Speed], StrictMode(False)]
Row2 = Annotated[tuple[Number, Number], StrictMode(False)]
Matrix2 = Annotated[tuple[Row2, Row2], StrictMode(False)]
PositiveFloat = Annotated[float, Field(gt=0)]
#: A weight or penalty of a planner's cost: within [0, :data:`MAX_WEIGHT`].
Weight = Annotated[float, Field(ge=0, le=MAX_WEIGHT)]
#: A weight that must be positive: within [:data:`MIN_WEIGHT`, :data:`MAX_WEIGHT`].
PositiveWeight = Annotated[float, Field(ge=MIN_WEIGHT, le=MAX_WEIGHT)]
#: A length (m) of a tolerance, clearance or margin: within [0, :data:`MAX_LENGTH`].
Length = Annotated[float, Field(ge=0, le=MAX_LENGTH)]
#: A length that must be positive: within (0, :data:`MAX_LENGTH`].
PositiveLength = Annotated[float, Field(gt=0, le=MAX_LENGTH)]


class Strict(BaseModel):
    """Base: unknown keys are errors, NaN and infinity are rejected, and values are strict.

    Strict mode means a number field takes an int or a float but never a bool (YAML ``yes``) or a
    string (``"0.1"``), a bool field takes only ``true``/``false``, an int field only an integer.
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True, strict=True)
