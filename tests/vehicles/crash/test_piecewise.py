"""Piecewise crush-zone envelopes (one LPR per crush stage): fit, kernel evaluation, files."""

from __future__ import annotations

import numpy as np
import pytest

from railgym.vehicles.crash.fe import (
    export_crash_element_fmu,
    load_crash_surrogate,
    save_crash_surrogate,
)
from railgym.vehicles.crash.piecewise import PiecewiseEnvelope, fit_piecewise
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.scenario import load_scenario
from railgym.vehicles.crash.surrogate import build_crash_surrogate
from railgym.vehicles.crash.surrogate_model import _pack_models, _piece_rows
from surrogates.selection import factory_for

KNOTS = (0.003, 0.087, 0.587, 0.617, 2.05, 2.08)


def _stages(u: np.ndarray) -> np.ndarray:
    """The paper wall zone's stage forces (N) without folding wave: a rise, plateaus and
    30 mm ramps between them."""
    s = np.array((0.0, *KNOTS))
    f = np.array((0.0, 600e3, 600e3, 600e3, 2200e3, 2200e3, 3000e3))
    return np.interp(u, s, f)


def test_stages_with_kinks_are_recovered_where_one_polynomial_rings():
    rng = np.random.default_rng(0)
    u = np.sort(rng.uniform(0.0, 2.6, 4000))
    f = _stages(u)
    env, tables = fit_piecewise(u, f, KNOTS, seed=0, degrees=(1, 2, 4))
    assert len(env.pieces) == len(KNOTS) + 1 and len(tables) == len(KNOTS)
    grid = np.linspace(0.0, 2.6, 5001)
    err = np.abs(env.predict(grid[:, None]) - _stages(grid))
    # within 1 % of the top force off the knots (each piece also takes the samples 2 mm
    # beyond its knots, which bend the steep ramps' pieces a little), 6 % at them; a single
    # polynomial of the same data rings by far more
    near = np.min(np.abs(grid[:, None] - np.array(KNOTS)), axis=1) < 2e-3
    assert err[~near].max() < 0.01 * 3e6
    assert err.max() < 0.06 * 3e6
    one = factory_for("lpr", extrapolation="clip")(64).fit(u[:, None], f)
    assert np.abs(one.predict(grid[:, None]) - _stages(grid))[~near].max() > 5 * err[~near].max()
    # a rise with no samples below the first knot: the line from the origin
    assert env.predict(np.array([[0.0015]]))[0] == pytest.approx(300e3, rel=1e-6)


def test_kernel_evaluates_each_lane_on_its_own_piece():
    rng = np.random.default_rng(1)
    u = np.sort(rng.uniform(0.0, 2.6, 1500))
    f = _stages(u) * (1 + 0.15 * np.sin(2 * np.pi * u / 0.15))
    env, _ = fit_piecewise(u, f, KNOTS, seed=0, degrees=(1, 8, 24))
    lpr = _pack_models(env.pieces, [(0.0, 4e6)] * len(env.pieces))
    x = np.concatenate([rng.uniform(-0.1, 3.0, 57), np.array(KNOTS), [0.0, 2.6]])
    rows = np.zeros((6, x.size))  # t, b1, b2, f, scratch, piece
    _piece_rows(x, 0, len(env.pieces), lpr, x.size, *rows)
    np.testing.assert_allclose(rows[3], env.predict(x[:, None]), rtol=1e-9, atol=1e-3)
    assert list(rows[5].astype(int)) == list(env.piece_index(x))


def test_piecewise_elements_round_trip_and_refuse_fmu_export(tmp_path):
    sc = load_scenario("paper")
    ref = simulate_reference(sc)
    knots = {"wall": (*sc.wall.stroke, sc.wall.absorber_stroke)}
    sur = build_crash_surrogate(ref, nodes_per_car=8, knots=knots)
    wall = sur.elements["wall"]
    assert isinstance(wall.loading, PiecewiseEnvelope)
    assert not isinstance(sur.elements["interface"].loading, PiecewiseEnvelope)
    back = load_crash_surrogate(save_crash_surrogate(sur, tmp_path / "e.json"))
    u = np.linspace(-0.1, 2.5, 777)[:, None]
    np.testing.assert_array_equal(back.elements["wall"].loading.predict(u), wall.loading.predict(u))
    assert back.nodes_per_car == 8
    with pytest.raises(ValueError, match="piecewise envelope"):
        export_crash_element_fmu(wall, tmp_path / "w.fmu")
