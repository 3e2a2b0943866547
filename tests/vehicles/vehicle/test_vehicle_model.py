"""Whole-vehicle model: modes, frequency response with wheelset delays, geometric filtering,
one-bogie limit — each against an independent computation."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq

from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vehicle.lanes import LANES, LANES_MIN
from railgym.vehicles.vehicle.model import (
    N_MECH,
    PARALLEL_MIN,
    advance_parallel,
    advance_serial,
    check_variant,
    kernel_params,
    linear_state_space,
    lpr_arrays,
    new_arrays,
    wheelset_offsets,
)
from railgym.vehicles.vehicle.params import WholeVehicle
from railgym.vehicles.vehicle.simulate import simulate
from railgym.vehicles.vertical.simulate import simulate as simulate_v0

DT = 1e-3
SPEED = 40.0


def beam_mode(x, length):
    """Free–free beam mode from the characteristic equation, normalised at the centre."""
    bl = brentq(lambda s: np.cos(s) * np.cosh(s) - 1.0, 4.0, 5.0)
    sig = (np.cosh(bl) - np.cos(bl)) / (np.sinh(bl) - np.sin(bl))

    def raw(s):
        return np.cosh(bl * s) + np.cos(bl * s) - sig * (np.sinh(bl * s) + np.sin(bl * s))

    return raw(np.asarray(x) / length + 0.5) / raw(0.5)


def matrices(v: WholeVehicle):
    """M, C, K of q = [z_c, θ_c, q, z_b0, θ_b0, z_b1, θ_b1] and the wheel-input matrix G:
    generalised force = G @ (k·w + c·ẇ) per wheelset (front to rear)."""
    s = v.suspension
    a, b = v.bogie_semi_spacing, v.semi_wheelbase
    wq = 2 * np.pi * v.bending_frequency
    mq = v.bending_modal_mass
    phi_a = beam_mode(a, v.carbody_length)
    m = np.diag(
        [
            v.carbody_mass,
            v.carbody_pitch_inertia,
            mq,
            v.bogie_mass,
            v.bogie_pitch_inertia,
            v.bogie_mass,
            v.bogie_pitch_inertia,
        ]
    )
    k = np.zeros((7, 7))
    c = np.zeros((7, 7))
    k[2, 2] = mq * wq**2
    c[2, 2] = 2 * v.bending_damping * mq * wq
    g = np.zeros((7, 4))
    for i, xi in enumerate((a, -a)):
        sec = np.zeros(7)  # δ_i = z_b,i − z_c − x_i θ_c − φ(a) q
        sec[[3 + 2 * i, 0, 1, 2]] = 1.0, -1.0, -xi, -phi_a
        k += s.k2 * np.outer(sec, sec)
        c += s.c2 * np.outer(sec, sec)
        for j, e in enumerate((b, -b)):
            prim = np.zeros(7)  # wheelset point of the bogie frame
            prim[[3 + 2 * i, 4 + 2 * i]] = 1.0, e
            k += 0.5 * s.k1 * np.outer(prim, prim)
            c += 0.5 * s.c1 * np.outer(prim, prim)
            g[:, 2 * i + j] = 0.5 * prim
    return m, c, k, g, phi_a


def analytic_floor_response(v: WholeVehicle, f: float, speed: float) -> np.ndarray:
    """Complex floor accelerations (front, centre, rear) for z_rear(t) = Re e^{jωt} (m)."""
    m, c, k, g, _ = matrices(v)
    w = 2 * np.pi * f
    s = v.wheelset_positions - v.wheelset_positions[-1]
    wheel = np.exp(1j * w * s / speed)  # wheelset j leads the rear one by s_j / v
    s1 = v.suspension
    force = g @ ((s1.k1 + 1j * w * s1.c1) * wheel)
    q = np.linalg.solve(-(w**2) * m + 1j * w * c + k, force)
    xf = v.floor_positions
    return -(w**2) * (q[0] + xf * q[1] + beam_mode(xf, v.carbody_length) * q[2])


def sine_track(wavelength, n_samples, speed=SPEED, amplitude=1e-3):
    t = np.arange(n_samples) * DT
    w = 2 * np.pi * speed / wavelength
    return amplitude * np.sin(w * t), amplitude * w * np.cos(w * t), w


def steady_phasor(y, t, w):
    """Least-squares phasor of y ≈ Re(X e^{jωt})."""
    basis = np.stack([np.cos(w * t), -np.sin(w * t)], axis=1)
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    return coef[0] + 1j * coef[1]


def test_loaded_parameters_follow_the_benchmark(vehicle):
    assert vehicle.carbody_mass == 32000.0 and vehicle.bogie_semi_spacing == 9.5
    assert vehicle.suspension.m2 == 16000.0  # each bogie carries half the carbody
    # the modal mass in the YAML is the uniform-beam value for the centre normalisation
    x = np.linspace(-13.0, 13.0, 20001)
    ratio = np.trapezoid(beam_mode(x, 26.0) ** 2, x) / 26.0
    assert vehicle.bending_modal_mass == pytest.approx(ratio * 32000.0, rel=1e-4)


def test_modal_frequencies_match_independent_eigenvalues(vehicle):
    s = replace(vehicle.suspension, c1=0.0, c2=0.0)
    v = replace(vehicle, suspension=s, bending_damping=0.0)
    m, _, k, _, _ = matrices(v)
    f_ref = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(m, k)).real)) / (2 * np.pi)
    a, *_ = linear_state_space(v)
    f_model = np.sort(np.abs(np.linalg.eigvals(a).imag))[::2] / (2 * np.pi)
    np.testing.assert_allclose(f_model, f_ref, rtol=1e-2)
    np.testing.assert_allclose(f_model, f_ref, rtol=1e-9)  # in fact to round-off
    # bounce ≈ 1.07 Hz, pitch ≈ 1.29 Hz, bending near the YAML's 10 Hz (coupled)
    assert 1.0 < f_ref[0] < 1.1 and 1.25 < f_ref[1] < 1.35
    assert np.min(np.abs(f_ref - 10.0)) < 0.2


def test_frequency_response_matches_transfer_function_with_delays(vehicle):
    freqs = np.array([0.5, 0.8, 1.1, 1.4, 2.0, 3.5, 5.0, 7.2, 10.0, 15.0])
    t_end, sample = 12.0, 5
    n_steps = int(t_end / (DT * sample))
    off = wheelset_offsets(vehicle, SPEED, DT)
    n_samples = n_steps * sample + int(np.ceil(off[0])) + 2
    z, zd = np.zeros((10, n_samples)), np.zeros((10, n_samples))
    for i, f in enumerate(freqs):
        z[i], zd[i], _ = sine_track(SPEED / f, n_samples)
    res = simulate("linear", vehicle, z, zd, off, DT, n_steps, sample)
    t = (np.arange(n_steps) + 1) * sample * DT
    keep = t > 8.0
    for i, f in enumerate(freqs):
        expect = analytic_floor_response(vehicle, f, SPEED) * -1e-3j  # sin = Re(−j·e^{jωt})
        got = np.array(
            [steady_phasor(res["acc"][i, keep, p], t[keep], 2 * np.pi * f) for p in range(3)]
        )
        scale = np.max(np.abs(expect))
        np.testing.assert_allclose(got, expect, atol=1e-2 * scale, err_msg=f"f = {f} Hz")
        big = np.abs(expect) > 0.1 * scale
        np.testing.assert_allclose(np.abs(got[big]), np.abs(expect[big]), rtol=1e-2)


@pytest.mark.parametrize("mult", [2.0, 4.0])
def test_geometric_filtering_of_bogie_spacing(vehicle, mult):
    """λ = 2a·2 (= 4a): bogies in anti-phase, no bounce or bending at the centre;
    λ = 2a: bogies in phase, no pitch (front and rear floor points move alike)."""
    a = vehicle.bogie_semi_spacing
    off = wheelset_offsets(vehicle, SPEED, DT)
    n_steps = 2000
    z, zd, w = sine_track(mult * a, n_steps * 5 + int(off[0]) + 2)
    res = simulate("linear", vehicle, z, zd, off, DT, n_steps, 5)
    t = (np.arange(n_steps) + 1) * 5 * DT
    keep = t > 6.0
    ph = [abs(steady_phasor(res["acc"][0, keep, p], t[keep], w)) for p in range(3)]
    expect = np.abs(analytic_floor_response(vehicle, SPEED / (mult * a), SPEED)) * 1e-3
    np.testing.assert_allclose(ph, expect, atol=1e-3 * max(ph))
    pitch = np.abs(steady_phasor(res["states"][0, keep, 8], t[keep], w))
    if mult == 4.0:
        assert ph[1] < 1e-4 * ph[0] and expect[1] < 1e-12
    else:
        assert abs(ph[0] - ph[2]) < 1e-4 * ph[0] and pitch < 1e-6 * w


@pytest.mark.parametrize("variant", ["linear", "dynamic"])
def test_rigid_zero_spacing_reproduces_one_bogie_model(vehicle, variant):
    """a = b = 0, huge pitch inertia, bending decoupled: each bogie is the v0 model.
    Tolerance: 1e-9 of the RMS (the two kernels add the same terms in another order)."""
    rigid = replace(vehicle, bogie_semi_spacing=0.0, semi_wheelbase=0.0, carbody_pitch_inertia=1e12)
    rng = np.random.default_rng(3)
    n = 3001
    t = np.arange(n) * DT
    z = sum(
        1e-3 * rng.uniform() * np.sin(2 * np.pi * f * t + rng.uniform(0, 6))
        for f in (0.9, 1.7, 4.0, 8.5)
    )
    zd = np.gradient(z, DT)
    ref = simulate_v0(variant, vehicle.suspension, z, zd, DT)
    res = simulate(variant, rigid, z, zd, np.zeros(4), DT, n - 1, flexible=False)
    for p in range(3):
        got = res["acc"][0, :, p]
        scale = np.sqrt(np.mean(ref["a2"][1:] ** 2))
        np.testing.assert_allclose(got, ref["a2"][1:], atol=1e-9 * scale)
    for p in (3, 4):
        np.testing.assert_allclose(
            res["acc"][0, :, p], ref["a1"][1:], atol=1e-9 * np.sqrt(np.mean(ref["a1"] ** 2))
        )


def test_kernel_freezes_a_diverging_vehicle(vehicle):
    z = np.zeros((1, 500))
    zd = np.zeros((1, 500))
    z[0, 10:] = 50.0  # an impossible 50 m step drives the state past the divergence limit
    res = simulate("linear", vehicle, z, zd, np.zeros(4), DT, 40, 10)
    assert res["diverged"][0]
    assert np.all(np.isfinite(res["states"])) and np.all(np.isfinite(res["acc"]))
    assert res["states"].shape[2] == N_MECH


@pytest.mark.parametrize("variant", ["dynamic", "surrogate"])
def test_parallel_kernel_is_bit_identical_to_serial(vehicle, variant):
    """``advance_parallel`` (prange over chunks of vehicles) reproduces ``advance_serial`` bit
    for bit, a diverging vehicle included, on a batch above the parallel threshold."""
    off = wheelset_offsets(vehicle, SPEED, DT)
    n, n_sub = PARALLEL_MIN + 37, 50
    samples = int(off.max()) + 3 * n_sub + 2
    rng = np.random.default_rng(3)
    z = 1e-3 * np.cumsum(rng.standard_normal((n, samples)), axis=1)
    z[5, 1:] = 50.0  # an impossible step: this vehicle diverges
    force = rng.uniform(-2e3, 2e3, (n, 2))
    p = kernel_params(vehicle)
    e = vehicle.suspension.kernel_params().record()
    lpr = lpr_arrays(default_vertical_surrogate("static") if variant == "surrogate" else None)
    runs = []
    for step in (advance_serial, advance_parallel):
        bt, out = new_arrays(n, variant, samples)
        bt.z[:], bt.zdot[:] = z, np.gradient(z, DT, axis=1)
        bt.off[:] = off
        bt.force[:] = force
        for _ in range(3):
            step(check_variant(variant), bt, n_sub, DT, p, e, lpr, out)
            bt.k[:] += n_sub
        runs.append((bt.state, out.acc, out.fs, out.count, out.div))
    assert runs[0][4][5] and np.isfinite(runs[0][0]).all()
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("law", ["exact", "element"])
def test_parallel_kernel_with_dampers_is_bit_identical_to_serial(vehicle, law):
    """With controllable dampers (their law taken apart and rebuilt inside the ``prange``),
    ``advance`` on a batch above the parallel threshold reproduces ``advance_serial`` bit for
    bit; the dampers move (their states and forces are not zero)."""
    from railgym.vehicles.semi_active import load_damper
    from railgym.vehicles.semi_active_element import load_damper_element
    from railgym.vehicles.vehicle.damper import VehicleDampers
    from railgym.vehicles.vehicle.model import advance_parallel_dampers
    from railgym.vehicles.vertical.kernels import damper_law

    params = load_damper()
    kernel_law = damper_law(params, load_damper_element() if law == "element" else None)
    off = wheelset_offsets(vehicle, SPEED, DT)
    n, n_sub = PARALLEL_MIN + 21, 20
    samples = int(off.max()) + 3 * n_sub + 2
    rng = np.random.default_rng(5)
    z = 1e-3 * np.cumsum(rng.standard_normal((n, samples)), axis=1)
    command = rng.uniform(0.0, 1.0, (n, 2))
    p = kernel_params(vehicle)
    e = vehicle.suspension.kernel_params().record()
    lpr = lpr_arrays(None)
    runs = []
    for step in (advance_serial, advance_parallel_dampers):
        bt, out = new_arrays(n, "dynamic", samples, damper=True)
        bt.z[:], bt.zdot[:] = z, np.gradient(z, DT, axis=1)
        bt.off[:] = off
        for _ in range(3):
            step(
                check_variant("dynamic"),
                bt,
                n_sub,
                DT,
                p,
                e,
                lpr,
                out,
                VehicleDampers(kernel_law, command),
            )
            bt.k[:] += n_sub
        runs.append((bt.state, bt.force, out.acc, out.div))
    assert np.abs(runs[0][0][:, -4:]).max() > 0 and np.abs(runs[0][1]).max() > 0
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("n", [LANES_MIN + 3, 2 * LANES + 5, PARALLEL_MIN + 37])
def test_lane_kernel_is_bit_identical_to_the_per_vehicle_kernel(
    vehicle, n, assert_lanes_match_serial
):
    """``advance`` of the surrogate variant (the lane kernel, serial below ``PARALLEL_MIN``,
    on all threads above) equals ``advance_serial`` (one vehicle after another) bit for bit,
    through bump-stop contact, element inputs outside the box and divergence."""
    assert_lanes_match_serial(vehicle, lpr_arrays(default_vertical_surrogate("static")), n, DT)
