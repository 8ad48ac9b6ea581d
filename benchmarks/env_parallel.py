"""Environments stepped in parallel processes: environment steps per second with one process
and with two, at 3×3 (``sensing-temp``), with the run tables recorded and without
(``record=False``), through Gymnasium's vector environments and TorchRL's; for the scenario's
own team (the default team, whose adaptive estimator makes a step cost milliseconds) and for the
paper's team (an EKF: a step of a few hundred microseconds, where passing messages between
processes weighs more).

- Gymnasium: the team environment (``resilient_tracking/Team-v0``), ``SyncVectorEnv`` (one
  process) against ``AsyncVectorEnv`` (one process per environment, observations in shared
  memory), each holding the same two environments, stepped with random velocities drawn before
  the clock starts.
- TorchRL: the PettingZoo environment through ``PettingZooWrapper`` (agent mask on, as
  ``examples/learned_team`` trains), two ways: ``SerialEnv`` (one process) against
  ``ParallelEnv`` (one process per environment), two environments each, stepped together; and
  data collectors with random actions, ``Collector`` (one environment, in this process) against
  ``MultiSyncCollector`` (one environment in each of two processes, each collecting its share
  of a batch on its own).

Vector environments step their environments together, so each step waits for the slowest: a
step's cost varies (the default team's estimator switches from the EKF to the adaptive IMM
when its innovations reject the target model, an episode's end resets), and messages pass
between processes at every step. Collectors meet once per batch.

Every process runs one thread of linear algebra (set here unless the environment sets it),
as process-parallel training does. Each case first runs a few steps untimed; steps count every
environment's step (a vector step of two environments is two). The ratio is the two-process
rate over the one-process rate, measured side by side in one run.

    python -m benchmarks.env_parallel           # about two minutes
    python -m benchmarks.env_parallel --quick   # a smoke run
"""

from __future__ import annotations

import argparse
import functools
import os
import time
from typing import Any

# one thread of linear algebra per process: two processes on two cores, not four threads
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from benchmarks.common import machine, save, table  # noqa: E402
from benchmarks.env_steps import vector_rate  # noqa: E402

SCENARIO = "sensing-temp"
WORKERS = 2


def team_env(record: bool, team: str | None) -> Any:
    from resilient_tracking.env import TeamEnv

    return TeamEnv(SCENARIO, record=record, team=team)


def gymnasium_rate(parallel: bool, record: bool, team: str | None, steps: int) -> float:
    """Environment steps per second of two team environments in one vector (``parallel``: each
    in its own process)."""
    import gymnasium

    make = [functools.partial(team_env, record, team)] * WORKERS
    envs = (
        gymnasium.vector.AsyncVectorEnv(make, shared_memory=True)
        if parallel
        else gymnasium.vector.SyncVectorEnv(make)
    )
    return vector_rate(envs, steps)


def torchrl_env(record: bool, team: str | None) -> Any:
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper

    from resilient_tracking.env import parallel_env

    env = parallel_env(SCENARIO, record=record, retire=True, team=team)
    return PettingZooWrapper(
        env=env,
        group_map={"robots": list(env.possible_agents)},
        use_mask=True,
        categorical_actions=False,
        done_on_any=False,
    )


def torchrl_rate(parallel: bool, record: bool, team: str | None, steps: int) -> float:
    """Environment steps per second of two wrapped PettingZoo environments, rolled out with
    random actions (``parallel``: TorchRL's ``ParallelEnv``, else its ``SerialEnv``)."""
    from torchrl.envs import ParallelEnv, SerialEnv

    make = functools.partial(torchrl_env, record, team)
    envs = ParallelEnv(WORKERS, make) if parallel else SerialEnv(WORKERS, make)
    try:
        envs.set_seed(0)
        envs.rollout(10, break_when_any_done=False)
        start = time.perf_counter()
        envs.rollout(steps // WORKERS, break_when_any_done=False)
        return WORKERS * (steps // WORKERS) / (time.perf_counter() - start)
    finally:
        envs.close()


def collector_rate(parallel: bool, record: bool, team: str | None, steps: int) -> float:
    """Environment steps per second of TorchRL's data collectors with random actions: one
    environment in this process, or one in each of two processes (``parallel``)."""
    from torchrl.collectors import Collector, MultiSyncCollector

    make = functools.partial(torchrl_env, record, team)
    batch, total = 200, steps + 200
    collector: Any = (
        MultiSyncCollector([make] * WORKERS, None, frames_per_batch=batch, total_frames=total)
        if parallel
        else Collector(make, None, frames_per_batch=batch, total_frames=total)
    )
    try:
        batches = iter(collector)
        next(batches)  # untimed: the workers start, the first episodes reset
        start, frames = time.perf_counter(), 0
        for data in batches:
            frames += data.numel()
        return frames / (time.perf_counter() - start)
    finally:
        collector.shutdown()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    scale = 0.1 if args.quick else 1.0
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"load average (1 min): {load:.2f} on {os.cpu_count()} cores")
    rows, results = [], {}
    for library, rate, steps in (
        ("Gymnasium", gymnasium_rate, int(3000 * scale)),
        ("TorchRL", torchrl_rate, int(1000 * scale)),
        ("TorchRL collectors", collector_rate, int(2000 * scale)),
    ):
        for team in (None, "paper"):
            for record in (True, False):
                one = rate(False, record, team, steps)
                two = rate(True, record, team, steps)
                label = "recorded" if record else "record=False"
                who = team or "default"
                rows.append([library, who, label, one, two, two / one])
                results[f"{library}, {who}, {label}"] = {"one_process": one, "two_processes": two}
    header = ["library", "team", "run tables", "steps/s, 1 process", "steps/s, 2 processes"]
    print(table(rows, [*header, "ratio"]))
    path = save("env_parallel", {"machine": machine(), "scenario": SCENARIO, "rates": results})
    print(f"\nsaved {path}")


if __name__ == "__main__":
    main()
