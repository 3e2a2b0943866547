"""Vertical bogie–carbody model: analytic checks, convergence, element physics, kernel contract."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml

from railgym.track import track_time_input
from railgym.vehicles.vertical.elements import damper_force, damper_velocity
from railgym.vehicles.vertical.kernels import (
    KERNELS,
    STATE_SIZE,
    VARIANTS,
    initial_state,
    step_outputs,
    surrogate_arrays,
)
from railgym.vehicles.vertical.params import load_vehicle, vehicle_from_dict
from railgym.vehicles.vertical.simulate import element_response, simulate
from surrogates import LegendreRegression


@pytest.fixture(scope="module")
def veh():
    return load_vehicle("manchester")


@pytest.fixture(scope="module")
def raw():
    from importlib import resources

    path = resources.files("railgym").joinpath("configs", "vehicles", "manchester.yaml")
    return yaml.safe_load(path.read_text())


@pytest.fixture(scope="module")
def cubic_lpr(veh):
    """LPR fitted exactly (degree 3) to a smooth progressive spring + linear damper."""
    grid = np.meshgrid(np.linspace(-0.08, 0.08, 21), np.linspace(-1.5, 1.5, 21))
    U = np.c_[grid[0].ravel(), grid[1].ravel()]
    V = veh.k2 * U[:, 0] * (1 + 200.0 * U[:, 0] ** 2) + veh.c2 * U[:, 1]
    return LegendreRegression(degree=3).fit(U, V)


def _amplitude(t, x, w):
    """Complex amplitude X of x ≈ Im(X·e^{iωt}) by least squares."""
    A = np.c_[np.sin(w * t), np.cos(w * t)]
    (a, b), *_ = np.linalg.lstsq(A, x, rcond=None)
    return a + 1j * b


def _rel_rms(a, b):
    return np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2))


# -------------------------------------------------------------------------- vehicle data
def test_manchester_conventions(veh):
    assert (veh.m1, veh.m2) == (2615.0, 16000.0)
    assert veh.k1 == pytest.approx(4 * 1.22e6) and veh.c1 == pytest.approx(4 * 4e3)
    assert veh.k2 == pytest.approx(2 * 430e3) and veh.c2 == pytest.approx(2 * 20e3)
    # preload carries the carbody share; quasi-static air-spring stiffness is k2
    air = veh.air_spring
    preload = (veh.static_pressure - air.atmospheric_pressure) * air.effective_area * air.count
    assert preload == pytest.approx(veh.m2 * veh.gravity)
    k_static, k_closed = veh.air_spring_stiffness()
    assert k_static == pytest.approx(veh.k2, rel=0.005)
    assert k_closed > 2.0 * veh.k2


@pytest.mark.parametrize(
    ("section", "field", "value", "message"),
    [
        ("vehicle", "m1", -1.0, "vehicle.m1 must be positive"),
        ("vehicle", "k2", 0.0, "vehicle.k2 must be positive"),
        ("vehicle", "c1", float("nan"), "vehicle.c1 must be finite"),
        ("vehicle", "m2", "heavy", "vehicle.m2 must be a number"),
        ("damper", "blowoff_ratio", 1.5, "damper.blowoff_ratio must be in"),
        ("air_spring", "polytropic_index", 2.0, "air_spring.polytropic_index must be in"),
        ("air_spring", "count", 0, "air_spring.count must be positive"),
        ("bump_stop", "free_travel_rebound", -0.01, "bump_stop.free_travel_rebound must be"),
        ("air_spring", "bag_volume", 0.005, "air_spring.bag_volume is too small"),
    ],
)
def test_vehicle_validation_names_field(raw, section, field, value, message):
    d = copy.deepcopy(raw)
    d[section][field] = value
    with pytest.raises(ValueError, match=message):
        vehicle_from_dict(d)


def test_vehicle_missing_unknown_and_paths(raw, tmp_path):
    d = copy.deepcopy(raw)
    del d["vehicle"]["m1"]
    with pytest.raises(ValueError, match="vehicle.m1 is missing"):
        vehicle_from_dict(d)
    d = copy.deepcopy(raw)
    d["damper"]["c_rebund"] = 1.0
    with pytest.raises(ValueError, match="unknown field damper.c_rebund"):
        vehicle_from_dict(d)
    d = copy.deepcopy(raw)
    del d["air_spring"]  # a vehicle without an air spring: valid, but no dynamic reference
    no_air = vehicle_from_dict(d)
    assert no_air.air_spring is None and no_air.known_physics == ("bump_stop",)
    with pytest.raises(ValueError, match="air_spring section is missing.*dynamic reference"):
        simulate("dynamic", no_air, np.zeros(11), np.zeros(11), 1e-3)
    with pytest.raises(ValueError, match="unknown vehicle 'nosuch'"):
        load_vehicle("nosuch")
    d = copy.deepcopy(raw)
    d["vehicle"]["m1"] = 3000.0
    path = tmp_path / "heavy.yaml"
    path.write_text(yaml.safe_dump(d))
    assert load_vehicle(path).m1 == 3000.0
    assert load_vehicle(str(path)).m2 == 16000.0


# ---------------------------------------------------------------------- linear model
def test_linear_frequency_response_matches_analytic(veh):
    m1, m2, k1, c1, k2, c2 = veh.m1, veh.m2, veh.k1, veh.c1, veh.k2, veh.c2
    dt, Z, T = 1e-3, 0.002, 14.0
    t = np.arange(round(T / dt) + 1) * dt
    for f in np.geomspace(0.5, 20.0, 10):
        w = 2 * np.pi * f
        H = np.linalg.solve(
            [
                [k1 + k2 - w**2 * m1 + 1j * w * (c1 + c2), -(k2 + 1j * w * c2)],
                [-(k2 + 1j * w * c2), k2 - w**2 * m2 + 1j * w * c2],
            ],
            [k1 + 1j * w * c1, 0.0],
        )[1]
        r = simulate("linear", veh, Z * np.sin(w * t), Z * w * np.cos(w * t), dt)
        tail = t >= T - 4.0
        X2 = _amplitude(t[tail], r["x2"][tail], w) / Z
        assert abs(X2 - H) / abs(H) < 0.01, f
        # the reported acceleration is the second derivative of the displacement
        A2 = _amplitude(t[tail], r["a2"][tail], w) / Z
        assert abs(A2 + w**2 * H) / abs(w**2 * H) < 0.01, f


def test_rk4_order_with_sampled_sine_input(veh):
    """The Hermite midpoint of the samples keeps RK4's 4th order for a sampled smooth input
    (the average of two samples would give order 2)."""
    T, Z = 2.0, 0.002
    runs = []
    for dt in (4e-3, 2e-3, 1e-3, 5e-4):
        t = np.arange(round(T / dt) + 1) * dt
        w1, w2 = 2 * np.pi * 3.0, 2 * np.pi * 11.0
        z = Z * (np.sin(w1 * t) + 0.5 * np.sin(w2 * t + 1.0))
        zdot = Z * (w1 * np.cos(w1 * t) + 0.5 * w2 * np.cos(w2 * t + 1.0))
        runs.append(simulate("linear", veh, z, zdot, dt, sample_every=round(4e-3 / dt))["states"])
    diffs = [np.sqrt(np.mean((a - b) ** 2)) for a, b in zip(runs, runs[1:], strict=False)]
    orders = np.log2(np.array(diffs[:-1]) / np.array(diffs[1:]))
    assert np.all((orders > 3.7) & (orders < 4.3)), orders


def test_rk4_order_on_surrogate(veh, cubic_lpr):
    """Free vibration from an offset plus a constant actuator force (input exact at stages)."""
    T, x0 = 1.0, np.array([0.02, 0.0, -0.005, 0.1])
    runs = []
    for dt in (4e-3, 2e-3, 1e-3, 5e-4):
        n = round(T / dt)
        every = round(4e-3 / dt)
        r = simulate(
            "surrogate",
            veh,
            np.zeros(n + 1),
            np.zeros(n + 1),
            dt,
            force_a=5e3,
            surrogate=cubic_lpr,
            sample_every=every,
            x0=x0,
        )
        assert r["out_of_domain"] == 0
        runs.append(r["states"])
    diffs = [np.sqrt(np.mean((a - b) ** 2)) for a, b in zip(runs, runs[1:], strict=False)]
    orders = np.log2(np.array(diffs[:-1]) / np.array(diffs[1:]))
    assert np.all((orders > 3.6) & (orders < 4.4)), orders


def test_surrogate_of_linear_law_reproduces_linear_and_counts_domain(veh):
    """Degree-1 LPR of k2·δ + c2·δ̇ is exact, also when linearly extrapolated."""
    rng = np.random.default_rng(1)
    U = np.c_[rng.uniform(-1e-3, 1e-3, 50), rng.uniform(-0.01, 0.01, 50)]
    model = LegendreRegression(degree=1).fit(U, veh.k2 * U[:, 0] + veh.c2 * U[:, 1])
    tr = track_time_input(5, 40.0, 2.0, 1e-3, 3, wheelbase=2.56)
    ref = simulate("linear", veh, tr.z, tr.zdot, 1e-3)
    sur = simulate("surrogate", veh, tr.z, tr.zdot, 1e-3, surrogate=model)
    assert np.allclose(sur["a2"], ref["a2"], rtol=0, atol=1e-9 * np.abs(ref["a2"]).max())
    assert 0 < sur["out_of_domain"] <= 4 * (tr.z.size - 1)
    assert ref["out_of_domain"] == 0
    # with F_a = 0 the training output v = m2·a2 equals the element force
    assert np.allclose(ref["F_s"], veh.m2 * ref["a2"])


# ------------------------------------------------------------------- reference models
def test_dynamic_reference_step_halving(veh):
    accs = []
    for dt in (1e-3, 5e-4):
        tr = track_time_input(5, 40.0, 20.0, dt, 0, wheelbase=2.56)
        r = simulate("dynamic", veh, tr.z, tr.zdot, dt, sample_every=round(0.01 / dt))
        assert not r["diverged"]
        accs.append(r["a2"])
    assert np.sqrt(np.mean(accs[1] ** 2)) > 0.1  # a real ride, m/s²
    assert _rel_rms(accs[0], accs[1]) < 1e-5  # measured 1.2e-6


@pytest.mark.parametrize("variant", ["static", "dynamic"])
def test_equilibrium_stays_at_rest(veh, variant):
    n = 2000
    r = simulate(variant, veh, np.zeros(n + 1), np.zeros(n + 1), 1e-3)
    assert np.all(r["states"] == 0.0) and np.all(r["a2"] == 0.0) and r["contacts"] == 0


def test_bump_stop_counter_and_force(veh):
    b = veh.bump_stop
    x0 = np.array([0.055, 0.0, 0.0, 0.0])  # 15 mm into the bump stop
    n = 3000
    r = simulate("static", veh, np.zeros(n + 1), np.zeros(n + 1), 1e-3, x0=x0)
    d = r["x1"][1:] - r["x2"][1:]
    expected = np.count_nonzero((d > b.free_travel_compression) | (d < -b.free_travel_rebound))
    assert r["contacts"] == expected > 0
    # small motion never touches
    small = simulate("static", veh, np.zeros(n + 1), np.zeros(n + 1), 1e-3, x0=0.1 * x0)
    assert small["contacts"] == 0
    # bump-stop force: zero in the free travel, pushes apart beyond it, continuous, stiff
    delta = np.linspace(-0.08, 0.06, 1401)
    fb = element_response("static", veh, delta, np.zeros_like(delta), 1e-3)["bump_stop"]
    inside = (delta <= b.free_travel_compression) & (delta >= -b.free_travel_rebound)
    assert np.all(fb[inside] == 0.0)
    assert np.all(fb[delta > b.free_travel_compression] > 0)
    assert np.all(fb[delta < -b.free_travel_rebound] < 0)
    e = np.array([1e-4, 1e-3, 0.01, 0.02])
    fc = element_response("static", veh, b.free_travel_compression + e, 0 * e, 1e-3)["bump_stop"]
    onset = np.where(e < b.smoothing, e**2 / (2 * b.smoothing), e - b.smoothing / 2)
    assert fc == pytest.approx(b.stiffness * onset + b.cubic_stiffness * e**3, rel=1e-12)


def test_damper_curve_asymmetric_knee_and_inverse(veh):
    p = veh.kernel_params()
    d = veh.damper
    v = np.linspace(-1.0, 1.0, 2001)
    f = np.array([damper_force(x, p) for x in v])
    assert np.all(np.diff(f) > 0)
    back = np.array([damper_velocity(x, p) for x in f])
    assert np.allclose(back, v, rtol=0, atol=1e-12)
    assert damper_force(0.02, p) == pytest.approx(d.c_compression * 0.02, rel=0.01)
    assert damper_force(-0.02, p) == pytest.approx(-d.c_rebound * 0.02, rel=0.01)
    hi = (damper_force(0.8, p) - damper_force(0.6, p)) / 0.2
    assert hi == pytest.approx(d.blowoff_ratio * d.c_compression, rel=0.01)


def _in_phase(veh, f, X, dt):
    w = 2 * np.pi * f
    n = round(4 / f / dt)
    t = np.arange(n + 1) * dt
    r = element_response("dynamic", veh, X * np.sin(w * t), X * w * np.cos(w * t), dt)
    tail = t >= 2 / f
    F = _amplitude(t[tail], r["spring"][tail], w) / X
    return F.real, np.degrees(np.angle(F)), r


def test_dynamic_air_spring_frequency_dependence(veh):
    k_slow, phi_slow, _ = _in_phase(veh, 0.02, 0.005, 2e-3)
    k_fast, phi_fast, r = _in_phase(veh, 5.0, 0.005, 2e-4)
    k_20, phi_20, _ = _in_phase(veh, 20.0, 0.005, 1e-4)
    k_static, k_closed = veh.air_spring_stiffness()
    # quasi-static limit: the gas of bag and reservoir is compressed together
    assert k_slow == pytest.approx(k_static, rel=2e-3)
    assert k_slow == pytest.approx(veh.k2, rel=0.02)
    assert phi_slow < 1.0
    # the orifice throttles the flow to the reservoir: stiffer and lossy as frequency rises
    assert 1.005 * k_slow < k_fast < 1.1 * k_slow  # nearly static in the ride band
    assert phi_fast > 3.0  # hysteresis: energy lost in the orifice
    assert 1.3 * k_slow < k_20 < k_closed
    assert phi_20 > phi_fast
    # gas mass in bag + reservoir is conserved
    air = veh.air_spring
    p0, n = veh.static_pressure, air.polytropic_index
    rho0 = p0 / (air.gas_constant * air.temperature)
    t = np.arange(r["dp_b"].size) * 2e-4
    delta = 0.005 * np.sin(2 * np.pi * 5.0 * t)
    vb = air.bag_volume - air.effective_area * delta - 0.5 * air.area_gradient * delta**2
    mass = rho0 * (
        ((p0 + r["dp_b"]) / p0) ** (1 / n) * vb
        + ((p0 + r["dp_r"]) / p0) ** (1 / n) * air.reservoir_volume
    )
    assert np.ptp(mass) < 1e-6 * mass[0]
    assert np.ptp(r["dp_r"]) > 1e3


def test_dynamic_damper_is_maxwell(veh):
    """Series stiffness: damper force lags less than 90° and its stiffness shows at 20 Hz."""
    out = {}
    for f in (0.5, 20.0):
        w = 2 * np.pi * f
        dt = 1e-4
        t = np.arange(round(4 / f / dt) + 1) * dt
        X = 0.01 / w  # 10 mm/s velocity amplitude: below the knee
        r = element_response("dynamic", veh, X * np.sin(w * t), X * w * np.cos(w * t), dt)
        tail = t >= 2 / f
        out[f] = _amplitude(t[tail], r["damper"][tail], w) / X
    c = veh.damper
    kb = c.series_stiffness
    c_eff = out[0.5].imag / (2 * np.pi * 0.5)
    assert c_eff == pytest.approx((c.c_compression + c.c_rebound) / 2, rel=0.02)
    assert out[0.5].real < 0.01 * kb
    assert out[20.0].real > 0.2 * kb


# ------------------------------------------------------------------------ kernel API
def _batch_inputs(variant, n, seed=0):
    rng = np.random.default_rng(seed)
    N = 400
    z = np.empty((n, N + 1))
    zd = np.empty((n, N + 1))
    for i in range(n):
        tr = track_time_input(4, 35.0, N * 1e-3, 1e-3, 10 + i, wheelbase=2.56)
        z[i], zd[i] = tr.z, tr.zdot
    state = initial_state(variant, n)
    state[:, :4] = rng.normal(0, [0.005, 0.05, 0.005, 0.05], (n, 4))
    k0 = rng.integers(0, 200, n).astype(np.int64)
    fa = rng.normal(0, 2e3, n)
    return state, z, zd, k0, fa


def _outputs(n):
    return step_outputs(n)


@pytest.mark.parametrize("variant", VARIANTS)
def test_batch_equals_single_calls(veh, variant, cubic_lpr):
    n = 5
    lpr = surrogate_arrays(cubic_lpr if variant == "surrogate" else None)
    p = veh.kernel_params().record()
    kernel = KERNELS[variant]
    state, z, zd, k0, fa = _batch_inputs(variant, n)
    single = state.copy()
    batch_out = _outputs(n)
    for _ in range(3):
        kernel(state, z, zd, k0, 10, 1e-3, fa, p, lpr, batch_out)
        for i in range(n):
            s = single[i : i + 1]
            o = _outputs(1)
            kernel(
                s, z[i : i + 1], zd[i : i + 1], k0[i : i + 1], 10, 1e-3, fa[i : i + 1], p, lpr, o
            )
            for a, b in zip(o, batch_out, strict=True):
                assert np.array_equal(a[0], b[i])
        assert np.array_equal(state, single)
        k0 += 10
    assert state.shape[1] == STATE_SIZE[variant]
    assert np.all(np.abs(batch_out[0][:, 1]) > 0) and not batch_out[3].any()


@pytest.mark.parametrize("variant", ["linear", "dynamic"])
def test_nan_and_huge_inputs_set_diverged(veh, variant):
    n = 3
    state, z, zd, k0, fa = _batch_inputs(variant, n, seed=2)
    start = state.copy()
    fa[0] = np.nan
    z[1, k0[1] + 5] = 1e300
    zd[1, k0[1] + 5] = 1e300
    out = _outputs(n)
    acc, force, count, div = out
    KERNELS[variant](
        state, z, zd, k0, 10, 1e-3, fa, veh.kernel_params().record(), surrogate_arrays(), out
    )
    assert div.tolist() == [True, True, False]
    assert np.all(np.isfinite(state)) and np.all(np.isfinite(acc)) and np.all(np.isfinite(force))
    assert np.array_equal(state[0], start[0])  # frozen before the first bad substep
    assert np.all(acc[:2] == 0.0) and acc[2, 1] != 0.0
    with pytest.raises(ValueError, match="track index out of range"):
        k0[2] = z.shape[1] - 5
        KERNELS[variant](
            state, z, zd, k0, 10, 1e-3, fa, veh.kernel_params().record(), surrogate_arrays(), out
        )


def test_simulate_rejects_bad_input(veh, cubic_lpr):
    z = np.zeros(11)
    with pytest.raises(ValueError, match="variant must be one of"):
        simulate("quadratic", veh, z, z, 1e-3)
    with pytest.raises(ValueError, match="surrogate is required"):
        simulate("surrogate", veh, z, z, 1e-3)
    with pytest.raises(ValueError, match="zdot has shape"):
        simulate("linear", veh, z, z[:-1], 1e-3)
    with pytest.raises(ValueError, match="force_a must be a scalar or have shape"):
        simulate("linear", veh, z, z, 1e-3, force_a=np.zeros(3), sample_every=2)
    with pytest.raises(ValueError, match="dt must be"):
        simulate("linear", veh, z, z, -1.0)
    r = simulate("surrogate", veh, z, z, 1e-3, surrogate=cubic_lpr, sample_every=3)
    assert r["t"].tolist() == pytest.approx([0.0, 3e-3, 6e-3, 9e-3])
