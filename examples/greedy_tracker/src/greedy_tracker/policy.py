"""Greedy tracking: each sensing robot flies toward the nearest estimated target.

A baseline with no zone knowledge and no coordination: robot ``i`` picks the target ``j``
whose estimate (its league's) is nearest and commands ``u = gain · (d − standoff) · e``, with
``d`` the distance and ``e`` the unit vector to it, clipped into its velocity bounds. Robots
whose sensor is out hold still.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from resilient_tracking import Decision, Policy


class GreedyParams(BaseModel):
    """Parameters of the greedy policy, read from the scenario's ``policy.params``."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    gain: float = Field(1.0, gt=0, description="Speed (m/s) per metre of distance to close.")
    standoff: float = Field(0.5, ge=0, description="Distance (m) kept from the target.")


class GreedyPolicy(Policy):
    """Every sensing robot chases its nearest estimated target; the others hold."""

    name = "greedy"
    Params = GreedyParams
    learns_zones = False  # the team keeps no zone knowledge
    params: GreedyParams

    def act(self, belief, obs):
        """One velocity per robot from its league's target estimates."""
        m = obs.n_robots
        lower, upper = self.config.velocity_bounds(list(range(m)), obs.positions)
        controls = np.zeros((m, 2))
        modes = ["idle"] * m
        for k, league in enumerate(belief.leagues):
            targets = belief.estimates[k].mean[:, :2]
            for i in league:
                if not obs.sensing_ok[i]:
                    continue
                offsets = targets - obs.positions[i]
                distances = np.linalg.norm(offsets, axis=1)
                j = int(np.argmin(distances))
                if distances[j] > 0:
                    pull = self.params.gain * (distances[j] - self.params.standoff)
                    controls[i] = np.clip(pull * offsets[j] / distances[j], lower[i], upper[i])
                modes[i] = "greedy"
        return Decision(controls=controls, modes=modes)
