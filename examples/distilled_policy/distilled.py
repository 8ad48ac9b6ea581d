"""A small network distilled from the failure-aware planner, as a policy.

``features`` turns one robot's view (the observation of ``resilient_tracking.env``) into a
vector that does not depend on the number of robots; ``Network`` is a two-layer perceptron in
NumPy (fit by Adam on squared error); ``DistilledPolicy`` runs a trained network under
``rtrack run`` and ``rtrack compare`` as ``distilled:DistilledPolicy``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from resilient_tracking.policies import CallablePolicy

#: Where ``train.py`` writes the network and ``DistilledPolicy`` reads it (or
#: ``$DISTILLED_WEIGHTS``).
WEIGHTS = Path(__file__).with_name("weights.npz")
#: Targets, zones and teammates the features describe (nearest first).
TARGETS, ZONES, MATES = 3, 2, 2
SCALE = 5.0  # metres: relative positions are divided by it


def features(view: dict[str, np.ndarray]) -> np.ndarray:
    """One robot's view as a fixed vector: its own state, then the nearest targets, zones and
    league mates relative to it."""
    own = view["own"]
    here, u_max = own[:2], max(float(own[2]), 1e-9)
    parts = [np.array([own[3], own[4], own[5], own[6]])]

    gaps = view["targets"][:, :2] - here
    order = np.argsort(np.hypot(gaps[:, 0], gaps[:, 1]))[:TARGETS]
    rows = np.zeros((TARGETS, 6))
    for row, j in enumerate(order):
        cov = view["target_cov"][j]
        rows[row] = (
            *(gaps[j] / SCALE),
            *(view["targets"][j, 2:] / u_max),
            np.log1p(cov[0, 0] + cov[1, 1]),
            1.0,
        )
    parts.append(rows.ravel())

    zones = np.zeros((ZONES, 6))
    known = view["zones"][view["zones_mask"] > 0][:ZONES]  # nearest first already
    for row, z in enumerate(known):
        zones[row] = (*((z[:2] - here) / SCALE), np.sqrt(z[2] + z[4]) / SCALE, z[5], z[6], 1.0)
    parts.append(zones.ravel())

    mates = np.zeros((MATES, 3))
    others = view["teammates"][view["teammates_mask"] > 0] - here
    others = others[np.argsort(np.hypot(others[:, 0], others[:, 1]))][:MATES]
    for row, gap in enumerate(others):
        mates[row] = (*(gap / SCALE), 1.0)
    parts.append(mates.ravel())
    return np.concatenate(parts)


class Network:
    """``x → tanh(W3 tanh(W2 tanh(W1 x̂)))``: velocities as fractions of the speed bound, from
    standardized features ``x̂``."""

    def __init__(self, weights: dict[str, np.ndarray]):
        self.w = weights

    @classmethod
    def fit(
        cls,
        x: np.ndarray,
        y: np.ndarray,
        hidden: int = 64,
        epochs: int = 150,
        batch: int = 256,
        rate: float = 2e-3,
        seed: int = 0,
    ) -> Network:
        """Fit inputs ``x`` (S, F) to targets ``y`` (S, 2) in [-1, 1] by Adam on squared error."""
        rng = np.random.default_rng(seed)
        mean, std = x.mean(axis=0), x.std(axis=0) + 1e-6
        sizes = [x.shape[1], hidden, hidden, y.shape[1]]
        w: dict[str, np.ndarray] = {"mean": mean, "std": std}
        for k, (a, b) in enumerate(zip(sizes[:-1], sizes[1:], strict=True)):
            w[f"W{k}"] = rng.normal(0.0, 1.0 / np.sqrt(a), (a, b))
            w[f"b{k}"] = np.zeros(b)
        names = [n for n in w if n[0] in "Wb"]
        moments = {n: (np.zeros_like(w[n]), np.zeros_like(w[n])) for n in names}
        xs = (x - mean) / std
        t = 0
        for _ in range(epochs):
            for rows in np.array_split(rng.permutation(len(xs)), max(1, len(xs) // batch)):
                t += 1
                grads = cls._gradients(w, xs[rows], y[rows])
                for n in names:
                    m, v = moments[n]
                    m[:] = 0.9 * m + 0.1 * grads[n]
                    v[:] = 0.999 * v + 0.001 * grads[n] ** 2
                    step = m / (1 - 0.9**t) / (np.sqrt(v / (1 - 0.999**t)) + 1e-8)
                    w[n] -= rate * step
        return cls(w)

    @staticmethod
    def _gradients(w: dict[str, np.ndarray], x: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
        h0 = np.tanh(x @ w["W0"] + w["b0"])
        h1 = np.tanh(h0 @ w["W1"] + w["b1"])
        out = np.tanh(h1 @ w["W2"] + w["b2"])
        d2 = 2.0 * (out - y) / len(x) * (1 - out**2)
        d1 = (d2 @ w["W2"].T) * (1 - h1**2)
        d0 = (d1 @ w["W1"].T) * (1 - h0**2)
        return {
            "W2": h1.T @ d2,
            "b2": d2.sum(axis=0),
            "W1": h0.T @ d1,
            "b1": d1.sum(axis=0),
            "W0": x.T @ d0,
            "b0": d0.sum(axis=0),
        }

    def __call__(self, x: np.ndarray) -> np.ndarray:
        w = self.w
        h = np.tanh(((x - w["mean"]) / w["std"]) @ w["W0"] + w["b0"])
        h = np.tanh(h @ w["W1"] + w["b1"])
        return np.tanh(h @ w["W2"] + w["b2"])

    def save(self, path: Path) -> None:
        np.savez(path, **self.w)

    @classmethod
    def load(cls, path: Path) -> Network:
        with np.load(path) as data:
            return cls({name: data[name] for name in data.files})


class DistilledPolicy(CallablePolicy):
    """Each robot moves as the distilled network says, from its own view."""

    name = "distilled"
    mode = "distilled"

    def make_function(self):
        network = Network.load(Path(os.environ.get("DISTILLED_WEIGHTS", WEIGHTS)))

        def act(view: dict[str, np.ndarray]) -> np.ndarray:
            return network(features(view)) * view["own"][2]

        return act
