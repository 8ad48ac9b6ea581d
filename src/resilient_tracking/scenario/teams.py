"""Named teams: a name for a complete configuration of the team, chosen in one word.

A scenario says which team runs it (``team: paper``; ``rtrack run --team paper`` on the command
line); the team fills in every setting the scenario file leaves unsaid, so a scenario's own
settings still override its team's. ``default`` is what runs when nothing is said.

Each team is a set of settings by dotted path (:mod:`~resilient_tracking.scenario.paths`), so
``rtrack teams`` can list exactly what each fixes. Which team to pick is in the README and
docs/model.md §6.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from resilient_tracking.scenario.paths import set_path

__all__ = [
    "DEFAULT_TEAM",
    "NamedTeam",
    "TEAMS",
    "UnknownTeam",
    "get_team",
    "team_listing",
    "with_team_settings",
]


@dataclass(frozen=True)
class NamedTeam:
    """A team by name: a one-line summary and the settings it fixes, by dotted path."""

    name: str
    summary: str
    settings: Mapping[str, Any] = field(default_factory=dict)


class UnknownTeam(LookupError):
    """A team name that is not one of :data:`TEAMS`; the message lists the names."""

    def __str__(self) -> str:  # LookupError would quote the message
        return str(self.args[0])


#: The team that runs when a scenario names none.
DEFAULT_TEAM = "default"

#: What the default team adds to the settings' own defaults (docs/caution.md): the adaptive
#: estimator, which learns each target's process noise (docs/model.md §4.2), and each zone's
#: risk level priced by what its failure would cost (§6.7; the last sensors' guard is its
#: special case, so it is folded in).
_DEFAULT = {
    "estimator.type": "adaptive",
    "guards.priced.enabled": True,
    "guards.last_sensors.enabled": False,
}

#: The settings' own defaults on every path the default team changes: the paper's Algorithm 1
#: with the EKF and the paper's fixed risk levels. Every other team starts from these, so that
#: a team is the same whichever team the scenario it runs on names.
_FIXED = {
    "estimator.type": "ekf",
    "guards.priced.enabled": False,
    "guards.last_sensors.enabled": True,
}

#: The paper's method as written: its one-step program (eq. 9) and its constraint set (eqs. 7c,
#: 7d), none of the guards beyond the paper, with the provisional comm zone of a silent
#: teammate at the spread the paper's experiments are reproduced with (docs/model.md §10.1).
_PAPER = _FIXED | {
    "planner.program": "one_step",
    "guards.comm_hazard.enabled": False,
    "guards.last_sensors.enabled": False,
    "guards.safe_circling.enabled": False,
    "belief.provisional_zone.enabled": True,
    "belief.provisional_zone.std": 0.3,
}

#: Every mechanism for the world's features beyond the paper (docs/beyond.md).
_BEYOND = {
    "guards.quarantine.enabled": True,
    "guards.signal_turns.enabled": True,
    "guards.signal_turns.turns": 1.0,
    "belief.degradation_watch.enabled": True,
    "belief.zone_motion.enabled": True,
}

#: Every named team, in the order ``rtrack teams`` lists them.
TEAMS: dict[str, NamedTeam] = {
    team.name: team
    for team in (
        NamedTeam(
            "default",
            "the failure-aware team that runs when nothing is said: the paper's Algorithm 1"
            " on the route program, each zone's risk level priced by what its failure would"
            " cost, and the adaptive estimator",
            _DEFAULT,
        ),
        NamedTeam(
            "paper",
            "the paper's method exactly: one-step program, the paper's constraint set and"
            " settings (rtrack reproduce's team for the paper's experiments)",
            _PAPER,
        ),
        NamedTeam(
            "route",
            "the paper's method on the route program with the default guards, the EKF and"
            " the paper's fixed risk levels (rtrack reproduce's team for the paper's"
            " experiments repeated on the route program)",
            _FIXED,
        ),
        NamedTeam(
            "guarded",
            "the default team with the lure guard, where targets may lure robots into danger",
            _DEFAULT | {"guards.lure.enabled": True},
        ),
        NamedTeam(
            "beyond",
            "the default team with quarantine, signal turns, the degradation watch and zone"
            " motion, for moving, degrading and spreading zones",
            _DEFAULT | _BEYOND,
        ),
        NamedTeam(
            "vanilla",
            "the paper's baseline: fixed weights, no zone knowledge, no chance constraints",
            _FIXED | {"policy.name": "vanilla"},
        ),
        NamedTeam(
            "sog",
            "the risk-aware baseline after Mayya et al. (safety-aware observability Gramian)",
            _FIXED | {"policy.name": "sog"},
        ),
    )
}


def get_team(name: str) -> NamedTeam:
    """The team called ``name``; :class:`UnknownTeam` lists the names otherwise."""
    try:
        return TEAMS[name]
    except (KeyError, TypeError):
        raise UnknownTeam(
            f"unknown team {name!r}; choose from {', '.join(TEAMS)} (rtrack teams lists them)"
        ) from None


def team_listing() -> str:
    """Every team, one paragraph each: its name, its summary and the settings it fixes (what
    ``rtrack teams`` prints)."""
    blocks = []
    for team in TEAMS.values():
        lines = [f"{team.name}: {team.summary}"]
        lines += [f"    {path}: {_shown(value)}" for path, value in team.settings.items()]
        if not team.settings:
            lines.append("    nothing: the defaults")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def _shown(value: Any) -> str:
    """A setting's value as a scenario file writes it (``true``, not ``True``)."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def with_team_settings(data: dict[str, Any], team: NamedTeam) -> dict[str, Any]:
    """A copy of the scenario mapping ``data`` with each of ``team``'s settings set where
    ``data`` does not set that path itself (the scenario's own settings win)."""
    out = _copy(data)
    for path, value in team.settings.items():
        if not _is_set(out, path):
            set_path(out, path, _copy(value))
    return out


def _is_set(data: Any, path: str) -> bool:
    """Whether the dotted ``path`` leads to a value in ``data``; a step into something that is
    not a mapping counts as set, so that validation names the field as the file wrote it."""
    for key in path.split("."):
        if not isinstance(data, dict):
            return True
        if key not in data:
            return False
        data = data[key]
    return True


def _copy(value: Any) -> Any:
    """A copy of nested mappings and lists (the leaves are shared)."""
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_copy(v) for v in value]
    return value
