"""What the environments refuse before anything changes: a step with no episode running, an
action that is not a velocity of the agent's space, an action dictionary that does not name
exactly the live agents, and constructor or ``reset`` arguments of the wrong kind.

Each refusal is one line naming the argument or agent at fault; the environment is left as it
was (the same episode, at the same step, with the same next seed).
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Mapping
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

#: Kinds of NumPy arrays an action may be: integers and floats (what a ``float64`` ``Box``
#: can hold without loss of kind; booleans, complex numbers, text and objects are refused).
NUMBER_KINDS = "iuf"


class ResetNeeded(gymnasium.error.ResetNeeded, RuntimeError):
    """A step with no episode running: before the first ``reset()`` or after the episode
    ended (terminated or truncated). Both Gymnasium's ``ResetNeeded`` and a ``RuntimeError``."""


def integer(name: str, value: Any, least: int) -> int:
    """``value`` as an ``int`` if it is an integer (Python's or NumPy's, not a bool) of at
    least ``least``; else a ``TypeError`` or ``ValueError`` naming ``name``."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name}: expected an integer of at least {least}, got {value!r}")
    if value < least:
        raise ValueError(f"{name}: expected an integer of at least {least}, got {value!r}")
    return int(value)


def seed_value(name: str, value: Any) -> int | None:
    """A seed: ``None`` (the environment's next) or a non-negative integer."""
    return None if value is None else integer(name, value, 0)


def velocities(who: str, action: Any, space: spaces.Space[Any]) -> np.ndarray:
    """``action`` as a ``float64`` array of ``space``'s shape, refused (``TypeError`` naming
    ``who``) unless it holds real numbers, and (``ValueError``) unless it has that shape
    exactly: nothing is broadcast. Values out of the bounds are the session's to clip, values
    that are not finite its to hold (an invalid decision)."""
    try:
        array = np.asarray(action)
        got = type(action).__name__
    except ValueError:  # ragged nested sequences
        array, got = np.empty(0, dtype=object), f"a ragged {type(action).__name__}"
    if array.dtype.kind not in NUMBER_KINDS:
        got += f" of {array.dtype}" if isinstance(action, np.ndarray) else ""
        raise TypeError(f"{who}: expected {_expected(space)}, got {got}")
    if array.shape != space.shape:
        raise ValueError(
            f"{who}: expected {_expected(space)}, got shape {array.shape} (nothing is broadcast)"
        )
    return array.astype(np.float64, copy=False)


def _expected(space: spaces.Space[Any]) -> str:
    """What an action of ``space`` is, on one line."""
    return f"an array of real numbers of shape {space.shape} in {' '.join(repr(space).split())}"


def agents_acting(actions: Any, live: Iterable[str], retired: Iterable[str] = ()) -> None:
    """Refuse an action dictionary that is not one, names an agent that is neither live nor
    ``retired``, or leaves a live agent out (every live agent acts at each step of a parallel
    environment). Actions of retired agents are allowed (and ignored by the caller): TorchRL's
    PettingZoo wrapper sends one for every agent of a group."""
    live = list(live)
    if not isinstance(actions, Mapping):
        raise TypeError(
            f"actions: expected a dict from agent name to velocity, got {type(actions).__name__}"
        )
    retired = set(retired)
    unknown = [agent for agent in actions if agent not in live and agent not in retired]
    if unknown:
        raise ValueError(
            f"actions: unknown agent(s) {', '.join(map(repr, unknown))}; "
            f"the live agents are {', '.join(live)}"
        )
    missing = [agent for agent in live if agent not in actions]
    if missing:
        raise ValueError(
            f"actions: no action for {', '.join(missing)}; every live agent acts "
            f"({', '.join(live)})"
        )
