"""The memory (Maxwell-state) surrogate element inside the vertical kernels and its schema."""

from __future__ import annotations

import json

import numpy as np
import pytest

from railgym.envs.vertical.env import VerticalSuspensionEnv
from railgym.track import track_time_input
from railgym.vehicles.vertical.kernels import KERNELS, state_size, step_outputs, surrogate_arrays
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate
from surrogates import io
from surrogates.memory import element_form
from surrogates.models import model_class
from surrogates.models.checks import ModelFieldError
from surrogates.models.lpr import LegendreRegression
from surrogates.passive import PassiveLegendreRegression

VEH = load_vehicle("manchester")
DT = 1e-3
TAU = 8e-3


def _element(zeta_half_width: float = 4e-3, passive: bool = False) -> LegendreRegression:
    """A 3-input element ``F̂(δ, δ̇, ζ)`` fitted on a smooth nonlinear law over a box."""
    rng = np.random.default_rng(3)
    half = np.array([0.06, 0.6, zeta_half_width])
    U = half * rng.uniform(-1.0, 1.0, (600, 3))
    p = VEH.kernel_params()
    V = p.k2 * U[:, 0] * (1 + 40 * U[:, 0] ** 2) + 2e4 * np.tanh(U[:, 1] / 0.3) + 3e6 * U[:, 2]
    cls = PassiveLegendreRegression if passive else LegendreRegression
    model = cls(degree=(3, 3, 2)).fit(U, V)
    model.features_ = {"form": "maxwell", "tau": TAU, "known_physics": ["bump_stop"]}
    return model


def _bump(d: float) -> float:
    """Bump-stop law of the vehicle YAML, written out independently of the kernels."""
    b = VEH.bump_stop
    s = b.smoothing

    def ramp(e: float) -> float:
        return 0.0 if e <= 0 else (0.5 * e * e / s if e < s else e - 0.5 * s)

    ec, er = d - b.free_travel_compression, -d - b.free_travel_rebound
    f = 0.0
    if ec > 0:
        f += b.stiffness * ramp(ec) + b.cubic_stiffness * ec**3
    if er > 0:
        f -= b.stiffness * ramp(er) + b.cubic_stiffness * er**3
    return f


def _numpy_rk4(model, z, zdot, fa):
    """Independent RK4 of [x1, v1, x2, v2, s] with F = F̂(δ, δ̇, δ − s) + F_bump(δ)."""
    p = VEH.kernel_params()

    def rhs(x, zc, zdc, f_a):
        d, dd = x[0] - x[2], x[1] - x[3]
        u = np.array([[d, dd, d - x[4]]])
        out = int(np.any(u[0] < model.lower_) or np.any(u[0] > model.upper_))
        fs = float(model.predict(u)[0]) + _bump(d)
        acc1 = (p.k1 * (zc - x[0]) + p.c1 * (zdc - x[1]) - fs - f_a) / p.m1
        return np.array([x[1], acc1, x[3], (fs + f_a) / p.m2, (d - x[4]) / TAU]), out

    x = np.zeros(5)
    a2 = [rhs(x, z[0], zdot[0], fa[0])[0][3]]
    ood = 0
    for k in range(z.size - 1):
        za, zda, zb, zdb = z[k], zdot[k], z[k + 1], zdot[k + 1]
        zm = 0.5 * (za + zb) + DT / 8 * (zda - zdb)
        zdm = 1.5 / DT * (zb - za) - 0.25 * (zda + zdb)
        r1, o1 = rhs(x, za, zda, fa[k])
        r2, o2 = rhs(x + 0.5 * DT * r1, zm, zdm, fa[k])
        r3, o3 = rhs(x + 0.5 * DT * r2, zm, zdm, fa[k])
        r4, o4 = rhs(x + DT * r3, zb, zdb, fa[k])
        ood += o1 + o2 + o3 + o4
        x = x + DT / 6 * (r1 + 2 * r2 + 2 * r3 + r4)
        a2.append(rhs(x, zb, zdb, fa[k])[0][3])
    return np.array(a2), x, ood


def test_memory_element_in_the_kernel_equals_an_independent_numpy_rk4():
    """Maxwell state, 3-input LPR and the bump-stop law: kernel = numpy RK4 to rounding,
    with bump-stop contacts and out-of-domain stages (counted over all three inputs)."""
    model = _element(zeta_half_width=2e-3)
    _, z, zdot = track_time_input(3, 30.0, 1.5, DT, 7)
    # actuator force that pushes the deflection past the free travel
    amp = 1.5 * VEH.kernel_params().k2 * VEH.bump_stop.free_travel_compression
    fa = amp * np.sin(2 * np.pi * 1.5 * np.arange(z.size - 1) * DT)
    rec = simulate("surrogate", VEH, z, zdot, DT, force_a=fa, surrogate=model)
    a2, x_end, ood = _numpy_rk4(model, z, zdot, fa)
    assert rec["contacts"] > 0  # the bump-stop law acted
    assert rec["out_of_domain"] == ood > 0
    np.testing.assert_allclose(rec["a2"], a2, rtol=0, atol=1e-9 * np.abs(a2).max())
    np.testing.assert_allclose(rec["states"][-1], x_end, rtol=1e-9, atol=1e-12)
    # ζ = δ − s stays a first-order high-pass of δ: |ζ| well below the deflection range
    zeta = rec["x1"] - rec["x2"] - rec["states"][:, 4]
    assert np.abs(zeta).max() < 0.5 * np.abs(rec["x1"] - rec["x2"]).max()


def test_static_form_integrates_four_states_and_holds_a_fifth_still():
    """A 2-input element (the paper's static one) needs no Maxwell state; a 5-state array is
    accepted by the kernel, its fifth state held still; a memory element needs 5 states."""
    rng = np.random.default_rng(0)
    U = np.array([0.06, 0.6]) * rng.uniform(-1, 1, (300, 2))
    model = LegendreRegression(degree=(3, 3)).fit(U, 3e5 * U[:, 0] + 2e4 * U[:, 1])
    _, z, zdot = track_time_input(5, 40.0, 0.5, DT, 1)
    rec = simulate("surrogate", VEH, z, zdot, DT, surrogate=model)
    lpr = surrogate_arrays(model)
    assert lpr.tau == 0.0 and not lpr.bump and state_size("surrogate", lpr) == 4
    assert rec["states"].shape[1] == 4
    p, out = VEH.kernel_params().record(), step_outputs(1)
    s5 = np.array([[0.0, 0.0, 0.0, 0.0, 1e-3]])
    k0 = np.zeros(1, np.int64)
    KERNELS["surrogate"](s5, z[None], zdot[None], k0, 100, DT, np.zeros(1), p, lpr, out)
    np.testing.assert_allclose(s5[0, :4], rec["states"][100], rtol=1e-12, atol=1e-15)
    assert s5[0, 4] == 1e-3
    memory = surrogate_arrays(_element())
    with pytest.raises(ValueError, match="5 states"):
        KERNELS["surrogate"](
            s5[:, :4].copy(), z[None], zdot[None], k0, 1, DT, np.zeros(1), p, memory, out
        )


def test_tau_below_half_the_step_is_rejected():
    model = _element()
    model.features_ = {**model.features_, "tau": 4e-4}
    with pytest.raises(ValueError, match="features.tau"):
        surrogate_arrays(model, DT)
    _, z, zdot = track_time_input(5, 40.0, 0.1, DT, 1)
    with pytest.raises(ValueError, match="features.tau"):
        simulate("surrogate", VEH, z, zdot, DT, surrogate=model)


def test_form_and_input_count_must_agree():
    model = _element()
    model.features_ = {"form": "static"}
    with pytest.raises(ValueError, match="features.form|2 inputs"):
        surrogate_arrays(model)


@pytest.mark.parametrize("passive", [False, True])
def test_maxwell_element_round_trips_through_json(tmp_path, passive):
    model = _element(passive=passive)
    path = io.save(
        model,
        tmp_path / "m.json",
        inputs=["x1-x2", "v1-v2", "zeta"],
        output="F",
        units={"x1-x2": "m", "v1-v2": "m/s", "zeta": "m", "F": "N"},
        form="maxwell",
        tau=TAU,
        known_physics=["bump_stop"],
    )
    doc = json.loads(path.read_text())
    assert doc["schema_version"] == 2
    assert doc["features"]["form"] == "maxwell" and doc["features"]["tau"] == TAU
    back = io.load(path)
    assert type(back) is type(model)
    assert back.kind == ("lpr_passive" if passive else "lpr")
    assert element_form(back.features_) == ("maxwell", TAU, ("bump_stop",), None)
    U = np.random.default_rng(1).uniform(-0.05, 0.05, (50, 3))
    np.testing.assert_array_equal(back.predict(U), model.predict(U))
    assert all(
        np.array_equal(a, b)
        for a, b in zip(surrogate_arrays(back), surrogate_arrays(model), strict=True)
    )
    # the same file drives an env of the memory form
    env = VerticalSuspensionEnv(surrogate=path, duration=0.2)
    env.reset(seed=0)
    assert env.state.shape == (5,)
    assert model_class("lpr_passive") is PassiveLegendreRegression


def _v1_document(tmp_path):
    """A schema-version-1 file as written before the feature form existed."""
    rng = np.random.default_rng(0)
    U = rng.uniform(-1, 1, (100, 2))
    model = LegendreRegression(degree=3).fit(U, U[:, 0] ** 3 + U[:, 1])
    doc = io.model_to_document(model, inputs=["x1-x2", "v1-v2"], output="F")
    doc["schema_version"] = 1
    for key in ("form", "tau", "known_physics"):
        del doc["features"][key]
    return model, doc


def test_schema_version_1_loads_as_the_static_form(tmp_path):
    model, doc = _v1_document(tmp_path)
    path = tmp_path / "v1.json"
    path.write_text(json.dumps(doc))
    back = io.load(path)
    assert element_form(back.features_) == ("static", None, (), None)
    U = np.random.default_rng(2).uniform(-1, 1, (20, 2))
    np.testing.assert_array_equal(back.predict(U), model.predict(U))
    assert surrogate_arrays(back).tau == 0.0


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"form": "kelvin"}, "features.form"),
        ({"form": 3}, "features.form"),
        ({"form": "maxwell", "tau": None}, "features.tau"),
        ({"form": "maxwell", "tau": -1.0}, "features.tau"),
        ({"form": "static", "tau": 0.01}, "features.tau"),
        ({"known_physics": ["air_spring"]}, "features.known_physics"),
        ({"form": "maxwell", "tau": 0.01}, "inputs"),  # a 2-input model
    ],
)
def test_bad_feature_form_fails_naming_the_field(tmp_path, change, field):
    _, doc = _v1_document(tmp_path)
    doc["schema_version"] = 2
    doc["features"].update(change)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFieldError, match=field) as info:
        io.load(path)
    assert str(path) in str(info.value)
    if change.get("form") == "kelvin":
        assert "maxwell" in str(info.value) and "static" in str(info.value)
