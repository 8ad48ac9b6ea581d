"""Nearly-constant-velocity target model used by the estimator (docs/model.md §1, paper eq. 1).

State per target ``[px, py, vx, vy]``; white-acceleration noise with standard deviation
``accel_std`` (m/s²) per axis, discretised exactly for a step ``dt``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class NearlyConstantVelocity:
    dt: float
    accel_std: float

    @property
    def transition(self) -> FloatArray:
        """State transition ``A``."""
        a = np.eye(4)
        a[0, 2] = a[1, 3] = self.dt
        return a

    @property
    def process_noise(self) -> FloatArray:
        """Process noise ``Q`` of the discretised white-acceleration model."""
        dt, q = self.dt, self.accel_std**2
        block = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        out = np.zeros((4, 4))
        for axis in (0, 1):
            idx = np.ix_([axis, axis + 2], [axis, axis + 2])
            out[idx] = block
        return out
