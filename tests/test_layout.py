"""The league problem's named layout: parameters packed where the NLP's symbols read them,
and options that reject what they do not know."""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from helpers import inputs, structure_of
from resilient_tracking.planning.layout import PARAMETERS, ParameterLayout, Slots
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.planning.solver_options import ProblemOptions


@pytest.mark.parametrize("route", [False, True])
@pytest.mark.parametrize("slots", [None, Slots(1, 1, 1)])
def test_each_input_is_packed_where_its_symbol_is(slots, route):
    q = inputs(n=3, big_n=2, sensing_zones=2, comm_zones=1, seed=2)
    if route:  # the route program's rows are there only in its problems
        unlinked = np.array([[1.0, 0, 1], [0, 1, 0], [1, 0, 1]])
        q = replace(q, route=np.arange(12.0).reshape(3, 4), standoff=0.2, unlinked=unlinked)
    layout = ParameterLayout(structure_of(q), slots)
    symbols = layout.symbols()
    p = ca.veccat(*symbols.values())
    packed = ParameterLayout.pack(q)
    if slots:
        packed = np.concatenate([packed, np.zeros(int(p.shape[0]) - len(packed))])
    assert len(packed) == p.shape[0]
    present = [b for b in PARAMETERS if b.present(structure_of(q))]
    read = ca.Function("read", [p], [symbols[b.name] for b in present])
    values = read(packed)
    expected = {
        "positions": q.positions.T,
        "sensing": q.sensing[None, :],
        "targets": q.targets.T,
        "prior_info": np.stack(
            [q.prior_info[:, 0, 0], q.prior_info[:, 0, 1], q.prior_info[:, 1, 1]]
        ),
        "weights": q.weights[:, None],
        "sensor": q.sensor[:, None],
        "dt": np.array([[q.dt]]),
        "sensing_zones": q.sensing_zones.T,
        "comm_zones": q.comm_zones.T,
        **({"route": q.route.T, "unlinked": q.unlinked.T} if q.route is not None else {}),
    }
    assert [b.name for b in present] == list(expected)
    for block, value in zip(present, values, strict=True):
        np.testing.assert_array_equal(
            np.asarray(value.full()).reshape(expected[block.name].shape), expected[block.name]
        )


def test_the_nlp_packs_its_parameters_with_the_layout():
    q = inputs(n=2, big_n=2)
    problem = LeagueProblem(structure_of(q))
    assert len(problem.pack_params(q)) == LeagueNLP(structure_of(q)).n_params


@pytest.mark.parametrize("key", ["codegn", "ipopt_options", "qpoases"])
def test_unknown_option_keys_are_rejected_by_name(key):
    options = {key: {}} if key != "qpoases" else {"qpsol": "osqp", "qpoases": {}}
    with pytest.raises(ValueError, match=repr(key)):
        LeagueProblem(structure_of(inputs()), options=options)
    with pytest.raises(ValueError, match=repr(key)):
        LeaguePlanner(options=options)


def test_known_options_are_taken():
    options = ProblemOptions.of(
        {"codegen": False, "slots": None, "qpsol": "osqp", "osqp": {"verbose": False}}
    )
    assert options.codegen is False and options.slots is None
    assert options.qpsol_options() == {"verbose": False}
    assert ProblemOptions.of(None).qpsol_options()["printLevel"] == "none"


def test_an_input_left_at_none_is_packed_as_zeros():
    """How an optional per-robot input (per-robot waypoints, say) can be added in one line."""
    q = inputs(n=3, big_n=2)
    packed = ParameterLayout.pack(q)
    q.sensing = None
    without = ParameterLayout.pack(q)
    n = len(q.positions)
    np.testing.assert_array_equal(without[2 * n : 3 * n], np.zeros(n))
    np.testing.assert_array_equal(
        np.delete(without, range(2 * n, 3 * n)), np.delete(packed, range(2 * n, 3 * n))
    )
