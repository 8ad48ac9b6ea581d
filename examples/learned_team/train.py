"""Train a team with TorchRL, export it to ONNX and evaluate it, in one command.

IPPO: one actor and one critic shared by every robot, each acting on its own view, trained by
TorchRL's clipped PPO loss with generalized advantage estimation. The actor starts from the
failure-aware planner's demonstrations (behaviour cloning on the states of its own episodes,
``env.expert_actions()``), and the critic from those episodes' returns; PPO then improves on
them with the environment's reward, held near the demonstrated policy by a penalty on the
distance between the two policies' mean velocities (an anchor, as in demonstration-augmented
policy gradients). The checkpoint kept is the one after the ``WINDOW`` iterations with the
highest mean return (the reward: the team's belief, never the truth). Episodes run in the PettingZoo
environment through TorchRL's ``PettingZooWrapper`` with its agent mask: with ``retire=True``, a
robot that has lost its sensor and its radio for good leaves the episode and is masked out of
the loss. The reward is the environment's reward callable, here ``LogTraceReward``.

Training scenarios are the paper's six (episode seeds from 1000, never those compared) and
scenarios drawn from the generator at ``TRAIN_SEED``, not the stored generalization suite's
seed. Writes, in ``--out``: ``checkpoint.pt`` (the networks), ``curve.csv`` and ``curve.png``
(return and MSE along training), ``team.onnx`` (features and actor, the whole policy) and, with
``--eval-seeds``, a comparison against the vanilla and failure-aware teams (``compare/``).

    python examples/learned_team/train.py --out learned --minutes 28
"""

from __future__ import annotations

import argparse
import copy
import csv
import logging
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from tensordict import TensorDict
from tensordict.nn import TensorDictModule
from torchrl.envs.libs.pettingzoo import PettingZooWrapper
from torchrl.modules import IndependentNormal, ProbabilisticActor
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value.functional import generalized_advantage_estimate

sys.path.insert(0, str(Path(__file__).parent))
from model import FIELDS, Actor, Critic, ViewFeatures, export_onnx  # noqa: E402

from resilient_tracking import builtin_scenarios  # noqa: E402
from resilient_tracking.env import StepOutcome, parallel_env  # noqa: E402
from resilient_tracking.experiments.catalog import SIX  # noqa: E402
from resilient_tracking.experiments.generator import SUITE_SEED, suite  # noqa: E402
from resilient_tracking.scenario import Scenario  # noqa: E402

log = logging.getLogger("learned_team")

#: The generator seed of the training scenarios (the stored suite is drawn from SUITE_SEED).
TRAIN_SEED = 2026
assert TRAIN_SEED != SUITE_SEED
#: The first episode seed of training (the comparisons use seeds 1, 2, …).
FIRST_TRAINING_SEED = 1000
GROUP = "robots"
#: Iterations whose mean return chooses the checkpoint kept.
WINDOW = 10


@dataclass(frozen=True)
class LogTraceReward:
    """Each step: minus ``weight`` times the log of the team's position trace after it, minus
    ``attack_penalty`` per attack felt. The log keeps a team that has lost its sensors (trace
    in the hundreds) and one that tracks well (trace near 0.01) on one scale."""

    weight: float = 0.1
    attack_penalty: float = 1.0

    def __call__(self, outcome: StepOutcome) -> float:
        trace = max(outcome.trace_after, 1e-9)
        return -self.weight * math.log(trace) - self.attack_penalty * outcome.attacks


def training_scenarios(generated: int) -> list[Scenario]:
    """The paper's six scenarios and ``generated`` drawn at ``TRAIN_SEED``."""
    return [builtin_scenarios.load(name) for name in SIX] + suite(TRAIN_SEED, generated)


def wrapped(scenario: Scenario, steps: int | None) -> PettingZooWrapper:
    """The scenario's PettingZoo environment through TorchRL, every robot in one group."""
    options = {} if steps is None else {"steps": steps}
    env = parallel_env(scenario, record=False, retire=True, reward=LogTraceReward(), **options)
    return PettingZooWrapper(
        env=env,
        group_map={GROUP: list(env.possible_agents)},
        use_mask=True,
        categorical_actions=False,
        done_on_any=False,
    )


class Learner:
    """The shared networks, TorchRL's modules around them and the PPO loss."""

    def __init__(self, width: int = 64, rate: float = 1e-4, seed: int = 0, anchor: float = 1.0):
        torch.manual_seed(seed)
        self.actor, self.critic = Actor(width), Critic(width)
        #: the weight of the anchor to the demonstrated policy, and that policy (after imitate)
        self.anchor_weight, self.anchor = anchor, None
        self.features = TensorDictModule(
            ViewFeatures(),
            in_keys=[(GROUP, "observation", f) for f in FIELDS],
            out_keys=[(GROUP, "features")],
        )
        self.policy = self._probabilistic((GROUP,))
        self.loss = ClipPPOLoss(
            actor_network=self._probabilistic(()),
            critic_network=TensorDictModule(
                self.critic, in_keys=["features"], out_keys=["state_value"]
            ),
            clip_epsilon=0.1,
            entropy_coeff=0.0,
            normalize_advantage=True,
        )
        self.loss.set_keys(sample_log_prob="action_log_prob")
        self.optimiser = torch.optim.Adam(self.loss.parameters(), lr=rate)

    def _probabilistic(self, group: tuple[str, ...]) -> ProbabilisticActor:
        """The actor as a Gaussian policy on the keys under ``group``."""
        module = TensorDictModule(
            self.actor,
            in_keys=[(*group, "features"), (*group, "u_max")],
            out_keys=[(*group, "loc"), (*group, "scale")],
        )
        return ProbabilisticActor(
            module,
            in_keys={"loc": (*group, "loc"), "scale": (*group, "scale")},
            out_keys=[(*group, "action")],
            distribution_class=IndependentNormal,
            return_log_prob=True,
            log_prob_key=(*group, "action_log_prob"),
        )

    def act(self, td: TensorDict) -> TensorDict:
        """The rollout policy: features, then a sampled velocity and its log-probability."""
        self.features(td)
        own = td.get((GROUP, "observation", "own"))
        td.set((GROUP, "u_max"), own[..., 2:3].clamp_min(1e-6))
        return self.policy(td)

    def samples(self, rollout: TensorDict, gamma: float, lmbda: float) -> TensorDict:
        """One episode's acting robots' steps, flat: features, action, log-probability,
        advantage and value target (GAE, each robot along its own time axis)."""
        with torch.no_grad():
            nxt = self.features(rollout.get("next").clone()).get((GROUP, "features"))
            features = rollout.get((GROUP, "features"))
            value = self.critic(features).transpose(0, 1)
            next_value = self.critic(nxt).transpose(0, 1)
            reward = rollout.get(("next", GROUP, "reward")).transpose(0, 1)
            done = rollout.get(("next", GROUP, "done")).transpose(0, 1)
            terminated = rollout.get(("next", GROUP, "terminated")).transpose(0, 1)
            advantage, target = generalized_advantage_estimate(
                gamma, lmbda, value, next_value, reward, done, terminated
            )
        acting = rollout.get((GROUP, "mask"))
        flat = TensorDict(
            {
                "features": features,
                "u_max": rollout.get((GROUP, "u_max")),
                "action": rollout.get((GROUP, "action")).float(),
                "action_log_prob": rollout.get((GROUP, "action_log_prob")),
                "advantage": advantage.transpose(0, 1),
                "value_target": target.transpose(0, 1),
            },
            batch_size=acting.shape,
        )
        return flat[acting]

    def imitate(self, demos: TensorDict, epochs: int, minibatch: int = 256) -> float:
        """Behaviour cloning: fit the actor's mean velocity (as a fraction of the speed bound)
        to the expert's, and the critic to the returns; the last epoch's mean actor loss."""
        params = [*self.actor.net.parameters(), *self.critic.parameters()]
        optimiser = torch.optim.Adam(params, lr=1e-3)
        losses: list[float] = []
        for _ in range(epochs):
            losses = []
            for rows in torch.randperm(len(demos)).split(minibatch):
                batch = demos[rows]
                loc, _ = self.actor(batch["features"], batch["u_max"])
                fit = ((loc - batch["action"]) / batch["u_max"]).pow(2).mean()
                value = (self.critic(batch["features"]) - batch["return"]).pow(2).mean()
                optimiser.zero_grad()
                (fit + 0.1 * value).backward()
                optimiser.step()
                losses.append(fit.item())
        self.anchor = copy.deepcopy(self.actor).requires_grad_(False)
        return float(np.mean(losses))

    def update(self, batch: TensorDict, epochs: int, minibatch: int) -> dict[str, float]:
        """PPO epochs over ``batch``; the mean of each loss term."""
        totals: dict[str, list[float]] = {}
        for _ in range(epochs):
            for rows in torch.randperm(len(batch)).split(minibatch):
                part = batch[rows]
                terms = self.loss(part)
                loss = terms["loss_objective"] + terms["loss_critic"] + terms["loss_entropy"]
                if self.anchor is not None:
                    loc, _ = self.actor(part["features"], part["u_max"])
                    held, _ = self.anchor(part["features"], part["u_max"])
                    terms["loss_anchor"] = ((loc - held) / part["u_max"]).pow(2).mean()
                    loss = loss + self.anchor_weight * terms["loss_anchor"]
                self.optimiser.zero_grad()
                loss.backward()
                torch.nn.utils.clip_grad_norm_(self.loss.parameters(), 1.0)
                self.optimiser.step()
                for key in ("loss_objective", "loss_critic", "loss_entropy", "loss_anchor"):
                    if key in terms:
                        totals.setdefault(key, []).append(terms[key].item())
        return {key: float(np.mean(values)) for key, values in totals.items()}

    def state(self) -> dict[str, dict[str, torch.Tensor]]:
        """A copy of both networks' weights."""
        return copy.deepcopy({"actor": self.actor.state_dict(), "critic": self.critic.state_dict()})

    def save(self, path: Path, state: dict[str, dict[str, torch.Tensor]] | None = None) -> None:
        """Write ``state`` (default: the networks' weights now)."""
        torch.save(state or self.state(), path)

    def restore(self, state: dict[str, dict[str, torch.Tensor]]) -> None:
        self.actor.load_state_dict(state["actor"])
        self.critic.load_state_dict(state["critic"])

    @staticmethod
    def load_actor(path: Path, width: int = 64) -> Actor:
        """The actor of a checkpoint written by :meth:`save`."""
        actor = Actor(width)
        actor.load_state_dict(torch.load(path, weights_only=True)["actor"])
        return actor


def demonstrations(
    pool: list[Scenario],
    rng: np.random.Generator,
    minutes: float,
    episodes: int,
    steps: int | None,
    gamma: float,
) -> TensorDict:
    """The expert's (failure-aware planner's) episodes on scenarios drawn from ``pool``, until
    ``minutes`` of CPU time or ``episodes`` are spent: every robot's features, speed bound,
    the expert's velocity and the discounted return from there."""
    features, start, rows = ViewFeatures(), time.process_time(), []
    seed = FIRST_TRAINING_SEED
    while len(rows) < episodes and time.process_time() - start < 60 * minutes:
        options = {} if steps is None else {"steps": steps}
        scenario = pool[int(rng.integers(len(pool)))]
        env = parallel_env(scenario, seed=seed, record=False, reward=LogTraceReward(), **options)
        seed += 1
        env.reset()
        seen, actions, rewards = [], [], []
        while env.agents:
            views = env.session.views()
            expert = env.expert_actions()
            seen.append(views)
            actions.append(np.stack([expert[a] for a in env.possible_agents]))
            _, reward, *_ = env.step(expert)
            rewards.append(next(iter(reward.values())))
        returns = np.zeros(len(rewards))
        running = 0.0
        for t in reversed(range(len(rewards))):
            running = rewards[t] + gamma * running
            returns[t] = running
        with torch.no_grad():
            fields = [torch.from_numpy(np.stack([v[f] for v in seen])) for f in FIELDS]
            own = fields[0]
            m = own.shape[1]
            rows.append(
                TensorDict(
                    {
                        "features": features(*fields).flatten(0, 1),
                        "u_max": own[..., 2:3].clamp_min(1e-6).flatten(0, 1),
                        "action": torch.as_tensor(np.stack(actions), dtype=torch.float32).flatten(
                            0, 1
                        ),
                        "return": torch.as_tensor(returns, dtype=torch.float32).repeat_interleave(
                            m
                        )[:, None],
                    },
                    batch_size=[len(seen) * m],
                )
            )
        log.info("demonstration %d: %s, %d steps", len(rows), scenario.name, len(seen))
    return torch.cat(rows)


def train(
    out: Path,
    minutes: float,
    iterations: int | None,
    episodes: int,
    generated: int,
    steps: int | None,
    seed: int,
    demo_minutes: float,
    demo_episodes: int,
    anchor: float = 1.0,
) -> Learner:
    """Imitate the expert for ``demo_minutes`` (at most ``demo_episodes``), then run PPO until
    ``minutes`` of this process's CPU time in all (or ``iterations``) are spent; write the
    checkpoint and the curve in ``out``."""
    start = time.process_time()
    torch.set_num_threads(1)
    rng = np.random.default_rng(seed)
    pool = training_scenarios(generated)
    envs: dict[int, PettingZooWrapper] = {}
    learner = Learner(seed=seed, anchor=anchor)
    if demo_episodes:
        demos = demonstrations(pool, rng, demo_minutes, demo_episodes, steps, gamma=0.98)
        fit = learner.imitate(demos, epochs=30)
        log.info("imitation: %d samples, fit %.4g", len(demos), fit)
        learner.save(out / "imitation.pt")
    rows = []
    episode_seed, env_steps = FIRST_TRAINING_SEED, 0
    iteration = 0
    best, kept = -math.inf, learner.state()
    while (iterations is None or iteration < iterations) and (
        time.process_time() - start < 60 * minutes
    ):
        batches, returns, mses = [], [], []
        for _ in range(episodes):
            k = int(rng.integers(len(pool)))
            env = envs.setdefault(k, wrapped(pool[k], steps))
            env.set_seed(episode_seed)
            episode_seed += 1
            with torch.no_grad():
                rollout = env.rollout(100_000, learner.act, break_when_any_done=True)
            env_steps += rollout.batch_size[0]
            batches.append(learner.samples(rollout, gamma=0.98, lmbda=0.95))
            returns.append(float(rollout.get(("next", GROUP, "reward"))[:, 0].sum()))
            mses.append(float(rollout.get(("next", GROUP, "info", "mse"))[:, 0].nanmean()))
        terms = learner.update(torch.cat(batches), epochs=4, minibatch=512)
        iteration += 1
        row = {
            "iteration": iteration,
            "cpu_minutes": (time.process_time() - start) / 60,
            "env_steps": env_steps,
            "return": float(np.mean(returns)),
            "mse": float(np.nanmean(mses)),
            **terms,
        }
        rows.append(row)
        log.info("%s", " ".join(f"{k}={v:.4g}" for k, v in row.items()))
        recent = float(np.mean([r["return"] for r in rows[-WINDOW:]]))
        if len(rows) >= min(WINDOW, iterations or WINDOW) and recent > best:
            best, kept = recent, learner.state()
            log.info("kept: mean return %.4g over the last %d iterations", best, WINDOW)
    learner.save(out / "last.pt")
    learner.restore(kept)
    learner.save(out / "checkpoint.pt")
    with open(out / "curve.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return learner


def plot_curve(out: Path) -> Path:
    """``curve.png``: the mean episode return and MSE against environment steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    curve = pd.read_csv(out / "curve.csv")
    smooth = curve.rolling(10, min_periods=1).mean()
    fig, (left, right) = plt.subplots(1, 2, figsize=(9, 3.2))
    left.plot(curve["env_steps"], curve["return"], alpha=0.3, color="C0")
    left.plot(curve["env_steps"], smooth["return"], color="C0")
    left.set(xlabel="environment steps", ylabel="episode return")
    right.semilogy(curve["env_steps"], curve["mse"], alpha=0.3, color="C1")
    right.semilogy(curve["env_steps"], smooth["mse"], color="C1")
    right.set(xlabel="environment steps", ylabel="episode MSE [m²] (truth, logged)")
    fig.suptitle(f"IPPO with TorchRL: {curve['cpu_minutes'].iloc[-1]:.0f} CPU-minutes")
    fig.tight_layout()
    path = out / "curve.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("learned"))
    parser.add_argument("--minutes", type=float, default=28.0, help="CPU-minutes of training")
    parser.add_argument("--iterations", type=int, help="stop after this many iterations")
    parser.add_argument("--episodes", type=int, default=2, help="episodes per iteration")
    parser.add_argument("--generated", type=int, default=24, help="generated training scenarios")
    parser.add_argument("--steps", type=int, help="steps per training episode (default: each's)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--demo-minutes", type=float, default=8.0, help="CPU-minutes of expert episodes"
    )
    parser.add_argument(
        "--demo-episodes", type=int, default=1000, help="at most this many (0: no imitation)"
    )
    parser.add_argument(
        "--anchor", type=float, default=1.0, help="weight of the anchor to the cloned policy"
    )
    parser.add_argument(
        "--eval-seeds", type=int, default=3, help="compare on seeds 1..N (0: no comparison)"
    )
    parser.add_argument(
        "--eval-scenarios", nargs="+", default=list(SIX), help="default: the paper's six"
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    log.setLevel(logging.INFO)
    args.out.mkdir(parents=True, exist_ok=True)
    learner = train(
        args.out, args.minutes, args.iterations, args.episodes, args.generated, args.steps,
        args.seed, args.demo_minutes, args.demo_episodes, args.anchor,
    )  # fmt: skip
    plot_curve(args.out)
    model = export_onnx(learner.actor, args.out / "team.onnx")
    log.info("wrote %s", model)
    if args.eval_seeds:
        from resilient_tracking.cli import main as rtrack

        return rtrack(
            ["compare", *args.eval_scenarios, "--policies", f"vanilla,failure_aware,onnx:{model}",
             "--seeds", str(args.eval_seeds), "--out", str(args.out / "compare"), "-q"]
        )  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
