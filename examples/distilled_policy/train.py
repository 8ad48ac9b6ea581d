"""Distil the failure-aware planner into a small network by behaviour cloning on its own
episodes, then a few rounds of DAgger (the network drives, the planner labels the states it
reaches); writes ``weights.npz`` beside this file.

    python examples/distilled_policy/train.py [--seeds 2] [--rounds 1] [--steps STEPS]
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np
from distilled import WEIGHTS, Network, features

from resilient_tracking.env import parallel_env
from resilient_tracking.experiments.catalog import SIX

#: Training seeds start here, away from the seeds ``rtrack compare`` uses (0, 1, 2…).
FIRST_SEED = 1000


def episode(name: str, seed: int, steps: int, network: Network | None, rng: np.random.Generator):
    """Features and the planner's actions (fractions of the speed bound) at every state an
    episode reaches; the planner drives (``network`` None) or the network does."""
    env = parallel_env(name, steps=steps)
    observations, _ = env.reset(seed=seed)
    xs, ys = [], []
    while env.agents:
        expert = env.expert_actions()
        actions = {}
        for agent, view in observations.items():
            x = features(view)
            xs.append(x)
            ys.append(expert[agent] / view["own"][2])
            actions[agent] = expert[agent] if network is None else network(x) * view["own"][2]
        observations, *_ = env.step(actions)
    return xs, ys


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=2, help="episodes per scenario and round")
    parser.add_argument("--rounds", type=int, default=1, help="DAgger rounds after cloning")
    parser.add_argument("--steps", type=int, default=None, help="steps per episode")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    rng = np.random.default_rng(0)
    xs: list[np.ndarray] = []
    ys: list[np.ndarray] = []
    network = None
    started = time.perf_counter()
    for round_ in range(args.rounds + 1):
        for name in SIX:
            for s in range(args.seeds):
                seed = FIRST_SEED + 100 * round_ + s
                x, y = episode(name, seed, args.steps, network, rng)
                xs += x
                ys += y
        network = Network.fit(np.array(xs), np.clip(np.array(ys), -1.0, 1.0), seed=round_)
        error = np.mean((network(np.array(xs)) - np.array(ys)) ** 2)
        print(
            f"round {round_}: {len(xs)} samples, training error {error:.3f}, "
            f"{time.perf_counter() - started:.0f} s"
        )
    assert network is not None
    network.save(WEIGHTS)
    print(f"wrote {WEIGHTS}")


if __name__ == "__main__":
    main()
