"""Nonlinear relaxation law of the Maxwell state (``surrogates.memory``): the state against an
independent integration, the linear law equal to the exact Maxwell state, a synthetic
two-slope law recovered from element data, and the law's file round trip and checks."""

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from surrogates import io
from surrogates.memory import (
    fit_relaxation,
    maxwell_state,
    memory_features,
    relaxation_law,
    relaxation_rate,
    relaxed_state,
    shortest_time_constant,
    two_slope_relaxation,
)
from surrogates.models.checks import ModelFieldError
from surrogates.models.lpr import LegendreRegression

#: a damper-like law: 5 ms in compression, 8 ms in rebound, knees at 0.5 / 0.8 mm, blow-off 1/4
TRUE = (5e-3, 8e-3, 5e-4, 8e-4, 0.25)
DT = 2e-3


def deflection(t):
    """An analytic deflection history (m) with rates past the blow-off knees."""
    return 0.01 * np.sin(2 * np.pi * 1.3 * t) + 0.008 * np.sin(2 * np.pi * 7.0 * t + 0.4)


def piecewise(z, knots, rates):
    """Independent piecewise-linear law (numpy): interior by np.interp, linear beyond."""
    if z < knots[0]:
        return rates[0] + (rates[1] - rates[0]) / (knots[1] - knots[0]) * (z - knots[0])
    if z > knots[-1]:
        return rates[-1] + (rates[-1] - rates[-2]) / (knots[-1] - knots[-2]) * (z - knots[-1])
    return float(np.interp(z, knots, rates))


def test_two_slope_law_has_the_slopes_and_knees_it_is_given():
    knots, rates = two_slope_relaxation(*TRUE)
    tc, tr, zc, zr, ratio = TRUE
    for z, slope in ((0.3 * zc, 1 / tc), (-0.3 * zr, 1 / tr), (3 * zc, 1 / (ratio * tc))):
        h = 1e-7
        num = (relaxation_rate(z + h, knots, rates) - relaxation_rate(z - h, knots, rates)) / 2 / h
        assert num == pytest.approx(slope, rel=1e-6)
    assert relaxation_rate(-5 * zr, knots, rates) == pytest.approx(-(zr + 4 * zr / ratio) / tr)
    assert shortest_time_constant((knots, rates)) == pytest.approx(ratio * tc)
    for z in np.linspace(-4 * zr, 4 * zc, 37):
        assert relaxation_rate(z, knots, rates) == pytest.approx(piecewise(z, knots, rates))


def test_relaxed_state_matches_an_independent_integration():
    """ζ = δ − s of ``ṡ = g(δ − s)`` against scipy's adaptive RK45 on the same linear
    interpolation of the samples (the sampled record is all the element sees)."""
    t = np.arange(0, 1.0 + DT / 2, DT)
    d = deflection(t)
    law = two_slope_relaxation(*TRUE)
    zeta = relaxed_state(d, t, law)

    def rhs(tt, s):
        return [piecewise(np.interp(tt, t, d) - s[0], *law)]

    ref = solve_ivp(rhs, (0, t[-1]), [d[0]], t_eval=t, rtol=1e-10, atol=1e-13, max_step=DT / 4)
    ref_zeta = d - ref.y[0]
    assert ref_zeta.max() > 1.2 * TRUE[2] and ref_zeta.min() < -1.2 * TRUE[3]  # past the knees
    np.testing.assert_allclose(zeta, ref_zeta, rtol=0, atol=0.02 * np.abs(ref_zeta).max())


def test_linear_law_gives_the_maxwell_state():
    tau = 8e-3
    law = (np.array([-1.0, 0.0, 1.0]), np.array([-1.0, 0.0, 1.0]) / tau)
    t = np.arange(0, 0.6, DT)
    d = deflection(t)
    ref = maxwell_state(d, t, tau)
    np.testing.assert_allclose(relaxed_state(d, t, law), ref, atol=1e-3 * np.abs(ref).max())
    U = memory_features(d, np.gradient(d, t), t, form="maxwell", relaxation=law)
    np.testing.assert_allclose(U[:, 2], relaxed_state(d, t, law))


def synthetic_runs(n_runs=4, seconds=4.0):
    """Element data of a stiffness k in parallel with a stiffness k_s in series with the
    two-slope dashpot of :data:`TRUE`: ``F = k·δ + k_s·ζ``, random band-limited deflections."""
    k, ks = 8.6e5, 6.0e6
    law = two_slope_relaxation(*TRUE)
    rng = np.random.default_rng(3)
    t = np.arange(0, seconds, DT)
    runs = []
    for _ in range(n_runs):
        f = rng.uniform(0.5, 12.0, 6)
        a = rng.uniform(1e-3, 6e-3, 6) / np.sqrt(f)
        ph = rng.uniform(0, 2 * np.pi, 6)
        d = (a[:, None] * np.sin(2 * np.pi * f[:, None] * t + ph[:, None])).sum(0)
        dd = (
            a[:, None] * 2 * np.pi * f[:, None] * np.cos(2 * np.pi * f[:, None] * t + ph[:, None])
        ).sum(0)
        zeta = relaxed_state(d, t, law)
        rows = np.arange(50, t.size, 5)
        runs.append(
            {"t": t, "delta": d, "delta_dot": dd, "rows": rows, "force": (k * d + ks * zeta)[rows]}
        )
    return runs


def test_a_synthetic_two_slope_law_is_recovered():
    runs = synthetic_runs()
    fit = fit_relaxation(runs, degrees=(1, 1, 1), start=(8e-3, 8e-3, 1e-3, 1e-3, 0.5))
    np.testing.assert_allclose(fit.params, TRUE, rtol=0.03)
    V = np.concatenate([r["force"] for r in runs])
    assert fit.rms < 0.01 * np.sqrt(np.mean(V**2))


def element_with_law():
    rng = np.random.default_rng(0)
    U = rng.uniform([-0.05, -0.8, -0.004], [0.05, 0.8, 0.004], (300, 3))
    model = LegendreRegression(degree=(2, 2, 3)).fit(U, U @ [8.6e5, 2.0e4, 6.0e6])
    law = two_slope_relaxation(*TRUE)
    model.features_ = {
        "form": "maxwell",
        "tau": shortest_time_constant(law),
        "known_physics": [],
        "relaxation": {"zeta": law[0].tolist(), "rate": law[1].tolist()},
    }
    return model, law, U


def test_law_round_trips_through_a_version_3_file(tmp_path):
    model, law, U = element_with_law()
    path = io.save(model, tmp_path / "e.json")
    doc = json.loads(path.read_text())
    assert doc["schema_version"] == 3
    back = io.load(path)
    np.testing.assert_array_equal(back.features_["relaxation"]["zeta"], law[0])
    np.testing.assert_array_equal(back.features_["relaxation"]["rate"], law[1])
    np.testing.assert_array_equal(back.predict(U), model.predict(U))
    again = io.save(back, tmp_path / "f.json")
    assert again.read_text() == path.read_text()
    doc["schema_version"] = 2  # a version-2 reader would drop the law: refused
    (tmp_path / "g.json").write_text(json.dumps(doc))
    with pytest.raises(ModelFieldError, match="relaxation.*schema_version 3"):
        io.load(tmp_path / "g.json")


def test_element_without_a_law_is_still_written_as_version_2(tmp_path):
    model, _, _ = element_with_law()
    model.features_ = {"form": "maxwell", "tau": 8e-3, "known_physics": []}
    doc = json.loads(io.save(model, tmp_path / "e.json").read_text())
    assert doc["schema_version"] == 2 and "relaxation" not in doc["features"]


@pytest.mark.parametrize(
    ("law", "message"),
    [
        ({"zeta": [-1, 0, 1], "rate": [-1, 0, -2]}, "rate must be finite and strictly increasing"),
        ({"zeta": [-1, 1, 0], "rate": [-1, 0, 1]}, "zeta must be finite and strictly increasing"),
        ({"zeta": [-1, 0.5, 1], "rate": [-1, 0, 1]}, "contain 0 with rate 0"),
        ({"zeta": [-1, 0], "rate": [-1, 0]}, "length >= 3"),
        ({"zeta": [-1, 0, 1]}, "exactly the keys"),
        ({"zeta": ["a", 0, 1], "rate": [-1, 0, 1]}, "lists of numbers"),
    ],
)
def test_bad_laws_are_refused_naming_the_field(tmp_path, law, message):
    with pytest.raises(ValueError, match=message):
        relaxation_law(law)
    model, _, _ = element_with_law()
    doc = io.model_to_document(model)
    doc["features"]["relaxation"] = law
    (tmp_path / "e.json").write_text(json.dumps(doc))
    with pytest.raises(ModelFieldError, match="features.relaxation"):
        io.load(tmp_path / "e.json")
