"""The ``"maxwell_product"`` feature form (surrogates.memory): its inputs against an
independent integration of the Maxwell state, an analytic law reproduced to rounding by the
element fitted with the exact τ, its schema errors and its JSON round trip."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from surrogates import io
from surrogates.memory import FEATURE_FORMS, element_form, memory_features
from surrogates.models.checks import ModelFieldError
from surrogates.models.lpr import LegendreRegression
from surrogates.passive import PassiveLegendreRegression

TAU = 0.05  # s
#: the analytic law F = F0 + K0·δ + C·δ̇ + K1·ζ + KAPPA·δ·ζ (N, N/m, N s/m, N/m, N/m²)
F0, K0, C, K1, KAPPA = 300.0, 3.6e5, 2.0e3, 4.7e5, 4.0e6


def _record(seed: int = 0, n: int = 801, dt: float = 5e-3):
    """A deflection linear between its samples (m) with its own sampled rate (m/s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    f = np.geomspace(0.2, 15.0, 25)
    amp = 0.01 / np.sqrt(f) * rng.uniform(0.5, 1.0, f.size)
    ph = rng.uniform(0, 2 * np.pi, f.size)
    d = (amp * np.sin(2 * np.pi * np.outer(t, f) + ph)).sum(axis=1)
    dd = (amp * 2 * np.pi * f * np.cos(2 * np.pi * np.outer(t, f) + ph)).sum(axis=1)
    return t, d, dd


def _zeta_scipy(t, d, tau):
    """ζ̇ = δ̇ − ζ/τ with δ linear between the samples (slope per interval), by DOP853."""
    slope = np.diff(d) / np.diff(t)

    def rhs(s, z):
        k = min(int(np.searchsorted(t, s, side="right")) - 1, slope.size - 1)
        return [slope[k] - z[0] / tau]

    out = np.zeros(t.size)
    for k in range(t.size - 1):  # one solve per interval: the rate jumps at the samples
        sol = solve_ivp(rhs, (t[k], t[k + 1]), [out[k]], method="DOP853", rtol=1e-12, atol=1e-15)
        out[k + 1] = sol.y[0, -1]
    return out


def test_the_inputs_are_the_maxwell_state_and_its_product_with_the_deflection():
    t, d, dd = _record(n=201)
    U = memory_features(d, dd, t, TAU, "maxwell_product")
    assert U.shape == (t.size, len(FEATURE_FORMS["maxwell_product"])) == (201, 4)
    np.testing.assert_array_equal(U[:, :2], np.column_stack([d, dd]))
    np.testing.assert_allclose(U[:, 2], _zeta_scipy(t, d, TAU), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(U[:, 3], d * U[:, 2])
    np.testing.assert_array_equal(U[:, :3], memory_features(d, dd, t, TAU, "maxwell"))


@pytest.mark.parametrize("tau", [0.01, TAU, 0.2])
def test_the_element_with_the_exact_tau_reproduces_an_analytic_law_to_rounding(tau):
    """A spring K0 and dashpot C beside a Maxwell branch whose stiffness K1 + KAPPA·δ
    depends on the deflection (an air spring's bellows volume): the ζ of the law is
    integrated independently (scipy); the element fitted on the form's own features with
    the exact τ gives the law's force to rounding, also on another record."""
    t, d, dd = _record(seed=1)
    zeta = _zeta_scipy(t, d, tau)
    force = F0 + K0 * d + C * dd + K1 * zeta + KAPPA * d * zeta
    model = LegendreRegression(degree=(1, 1, 1, 1)).fit(
        memory_features(d, dd, t, tau, "maxwell_product"), force
    )
    t2, d2, dd2 = _record(seed=2)
    z2 = _zeta_scipy(t2, d2, tau)
    f2 = F0 + K0 * d2 + C * dd2 + K1 * z2 + KAPPA * d2 * z2
    pred = model.predict(memory_features(d2, dd2, t2, tau, "maxwell_product"))
    np.testing.assert_allclose(pred, f2, rtol=0, atol=1e-8 * np.abs(f2).max())
    # the additive form without the product input cannot: the coupling is 1 % of the force
    add = LegendreRegression(degree=(1, 1, 1)).fit(memory_features(d, dd, t, tau), force)
    assert np.sqrt(np.mean((add.predict(memory_features(d, dd, t, tau)) - force) ** 2)) > 1e-4 * (
        np.abs(force).max()
    )


@pytest.mark.parametrize(
    ("features", "n_inputs", "match"),
    [
        ({"form": "maxwell_product"}, 4, r"features\.tau.*positive time constant"),
        ({"form": "maxwell_product", "tau": -0.05}, 4, r"features\.tau"),
        ({"form": "maxwell_product", "tau": 0.05}, 3, r"'maxwell_product' has 4 inputs.*has 3"),
        (
            {"form": "maxwell_product", "tau": 0.05, "relaxation": [[-1, 0, 1], [-1, 0, 1]]},
            4,
            r"features\.relaxation' needs form 'maxwell'",
        ),
        ({"form": "maxwell2", "tau": 0.05}, 4, r"features\.form' must be one of"),
    ],
)
def test_schema_errors_name_the_field(features, n_inputs, match):
    with pytest.raises(ModelFieldError, match=match):
        element_form(features, n_inputs)


def test_a_relaxation_law_is_refused_by_the_product_feature_builder():
    t, d, dd = _record(n=21)
    with pytest.raises(ValueError, match="needs the 'maxwell' form"):
        memory_features(d, dd, t, TAU, "maxwell_product", relaxation=([-1, 0, 1], [-1, 0, 1]))


def _product_model():
    t, d, dd = _record(seed=3)
    U = memory_features(d, dd, t, TAU, "maxwell_product")
    force = F0 + K0 * d + C * dd + K1 * U[:, 2] + KAPPA * U[:, 3] + 2e8 * d**3
    model = PassiveLegendreRegression(degree=(3, 2, 2, 1), monotone=(True, True, True, False))
    return model.fit(U, force), U


def test_the_form_round_trips_through_json_and_a_wrong_input_count_is_refused(tmp_path):
    model, U = _product_model()
    path = io.save(model, tmp_path / "el.json", form="maxwell_product", tau=TAU)
    doc = json.loads(path.read_text())
    assert doc["schema_version"] == 2 and doc["features"]["form"] == "maxwell_product"
    back = io.load(path)
    assert element_form(back.features_) == ("maxwell_product", TAU, (), None)
    assert back.get_params() == model.get_params()
    np.testing.assert_array_equal(back.predict(U), model.predict(U))
    # the same file with a 3-input model: the field and both counts named
    doc3 = json.loads(path.read_text())
    three = LegendreRegression(degree=2).fit(U[:, :3], U[:, 0])
    doc3["model"] = three.to_dict()
    doc3["features"]["inputs"] = ["u1", "u2", "u3"]
    (tmp_path / "bad.json").write_text(json.dumps(doc3))
    with pytest.raises(ModelFieldError, match=r"'maxwell_product' has 4 inputs.*has 3"):
        io.load(tmp_path / "bad.json")
