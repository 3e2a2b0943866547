"""Property tests (hypothesis) of the surrogates package: LPR round trips, sampling
invariants, and a fuzz of the JSON model loader."""

from __future__ import annotations

import copy
import json
import math
from typing import Any

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from surrogates import LegendreRegression, io, select
from surrogates.models.checks import ModelFieldError

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def lpr_problems(draw: st.DrawFn) -> tuple[LegendreRegression, np.ndarray]:
    """A fitted LPR model on random data and query points inside and outside its box."""
    d = draw(st.integers(1, 3))
    interactions = draw(st.booleans())
    if interactions:
        degree: Any = draw(st.integers(0, 3))
    else:
        degree = tuple(draw(st.lists(st.integers(0, 4), min_size=d, max_size=d)))
    extrapolation = draw(st.sampled_from(["linear", "clip"]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.uniform(-3, 3, d)
    U = rng.uniform(-1.0, 1.0, (60, d)) * scale
    V = rng.standard_normal(60) * 10.0 ** rng.uniform(-3, 5)
    model = LegendreRegression(degree, interactions, extrapolation).fit(U, V)
    Q = rng.uniform(-2.0, 2.0, (25, d)) * scale
    return model, Q


@SETTINGS
@given(lpr_problems())
def test_lpr_json_round_trip_predicts_identically(problem):
    model, Q = problem
    back = LegendreRegression.from_dict(json.loads(json.dumps(model.to_dict())))
    np.testing.assert_array_equal(back.predict(Q), model.predict(Q))
    assert back.get_params() == {
        k: tuple(v) if isinstance(v, list) else v for k, v in model.get_params().items()
    }


@SETTINGS
@given(
    n=st.integers(2, 60),
    d=st.integers(1, 3),
    frac=st.floats(0.0, 1.0),
    method=st.sampled_from(["greedy", "random", "ga"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_selected_indices_are_unique_in_range_and_reproducible(n, d, frac, method, seed):
    X = np.random.default_rng(seed).normal(size=(n, d))
    m = max(1, round(frac * n))
    options = {"generations": 5, "population": 6} if method == "ga" else {}
    train, oob = select(X, m, method=method, seed=seed, **options)
    assert train.size == m and len(set(train.tolist())) == m
    assert np.all((train >= 0) & (train < n))
    np.testing.assert_array_equal(np.sort(np.concatenate([train, oob])), np.arange(n))
    again, _ = select(X, m, method=method, seed=seed, **options)
    np.testing.assert_array_equal(again, train)


RNG = np.random.default_rng(0)
_U = RNG.uniform(-1, 1, (40, 2))
VALID = io.model_to_document(LegendreRegression(degree=(3, 2)).fit(_U, _U[:, 0] ** 2 + _U[:, 1]))

garbage = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**12), 10**12)
    | st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308, 0.0, 1e9, -1.0])
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=5),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=4), inner, max_size=3)
    ),
    max_leaves=12,
)


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path (tuple of keys/indices) inside a JSON document."""
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node[:3]):
            out += _paths(v, (*prefix, i))
    return out


PATHS = _paths(VALID)[1:]


@settings(max_examples=300, deadline=None)
@given(
    edits=st.lists(
        st.tuples(st.sampled_from(PATHS), st.sampled_from(["drop", "set"]), garbage),
        min_size=1,
        max_size=3,
    )
)
def test_model_loader_fuzz_gives_a_clear_error_or_a_valid_model(tmp_path_factory, edits):
    doc = copy.deepcopy(VALID)
    for path, action, value in edits:
        node: Any = doc
        try:
            for key in path[:-1]:
                node = node[key]
            if action == "drop":
                del node[path[-1]]
            else:
                node[path[-1]] = value
        except (KeyError, IndexError, TypeError):
            continue  # an earlier edit removed or replaced this path
    file = tmp_path_factory.mktemp("fuzz") / "m.json"
    file.write_text(json.dumps(doc))
    try:
        model = io.load(file)
    except ModelFieldError as exc:
        assert str(file) in str(exc)
        return
    # accepted: a usable model whose predictions are finite inside its box
    lo, hi = model.domain_
    assert np.all(lo < hi)
    pred = model.predict(np.linspace(lo, hi, 7))
    assert np.all(np.isfinite(pred))
