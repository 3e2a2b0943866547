"""Tests of the Maxwell-state feature form against an analytic Maxwell element."""

from __future__ import annotations

import numpy as np
import pytest

from surrogates.memory import FEATURE_FORMS, maxwell_state, memory_features, select_tau
from surrogates.models.lpr import LegendreRegression
from surrogates.passive import PassiveLegendreRegression
from surrogates.selection import factory_for

K, C = 6.0e6, 4.0e4  # series spring N/m, damper N·s/m (the reference's bush and damper)
TAU = C / K


class Maxwell:
    """Spring ``K`` in series with damper ``C`` under a random-phase multi-sine deflection.

    ``δ(t) = Σ a_i cos(ω_i t + φ_i)`` between 2 and 40 Hz; the steady-state force is
    ``F = Σ a_i |H_i| cos(ω_i t + φ_i + arg H_i)``, ``H = K·iωτ/(1 + iωτ)``, ``τ = C/K``.
    """

    def __init__(self, seed: int, duration: float = 4.0, dt: float = 1e-3) -> None:
        rng = np.random.default_rng(seed)
        f = np.arange(2.0, 40.0, 0.25)
        self.w = 2 * np.pi * f
        self.a = 2e-3 / np.sqrt(f.size) * rng.uniform(0.5, 1.5, f.size)
        self.phase = rng.uniform(0.0, 2 * np.pi, f.size)
        self.H = K * 1j * self.w * TAU / (1 + 1j * self.w * TAU)
        self.t = np.arange(0.0, duration, dt)
        theta = np.outer(self.t, self.w) + self.phase
        self.delta = np.cos(theta) @ self.a
        self.delta_dot = -np.sin(theta) @ (self.a * self.w)
        self.force = np.cos(theta + np.angle(self.H)) @ (np.abs(self.H) * self.a)

    def static_spread(self) -> float:
        """RMS of ``F − E[F | δ, δ̇]`` relative to the RMS of ``F`` (analytic).

        For a Gaussian deflection the conditional mean is linear in ``(δ, δ̇)`` (uncorrelated
        for a stationary process), so the spread is
        ``√(1 − ⟨Fδ⟩²/(⟨F²⟩⟨δ²⟩) − ⟨Fδ̇⟩²/(⟨F²⟩⟨δ̇²⟩))`` with the exact time averages
        ``⟨δ²⟩ = Σa²/2``, ``⟨δ̇²⟩ = Σa²ω²/2``, ``⟨F²⟩ = Σa²|H|²/2``, ``⟨Fδ⟩ = Σa² Re H/2``,
        ``⟨Fδ̇⟩ = Σa² ω Im H/2``.
        """
        a2 = self.a**2 / 2
        ff = np.sum(a2 * np.abs(self.H) ** 2)
        fd = np.sum(a2 * self.H.real)
        fv = np.sum(a2 * self.w * self.H.imag)
        return float(np.sqrt(1 - fd**2 / (ff * np.sum(a2)) - fv**2 / (ff * np.sum(a2 * self.w**2))))


def rel_rms(pred: np.ndarray, true: np.ndarray) -> float:
    return float(np.sqrt(np.mean((pred - true) ** 2) / np.mean(true**2)))


def test_maxwell_state_is_the_damper_displacement():
    """With τ = C/K and the exact start, K·ζ reproduces the analytic force."""
    m = Maxwell(0)
    zeta0 = float(np.cos(m.phase + np.angle(m.H)) @ (np.abs(m.H) * m.a)) / K
    zeta = maxwell_state(m.delta, m.t, TAU, zeta0)
    # first-order hold: error of order (ω·dt)²/12 of the 40 Hz content, second order in dt
    err = rel_rms(K * zeta, m.force)
    assert err < 5e-3
    fine = Maxwell(0, dt=5e-4)
    err_fine = rel_rms(K * maxwell_state(fine.delta, fine.t, TAU, zeta0), fine.force)
    assert 3.5 < err / err_fine < 4.5
    # a relaxed start converges within a few τ
    relaxed = maxwell_state(m.delta, m.t, TAU)
    late = m.t > 10 * TAU
    assert rel_rms(K * relaxed[late], m.force[late]) < 5e-3
    assert rel_rms(K * relaxed[~late], m.force[~late]) > 1e-2


def test_memory_element_recovers_maxwell_force_where_static_map_cannot():
    train, test = Maxwell(1), Maxwell(2)
    spread = test.static_spread()
    assert spread > 0.3  # strongly hysteretic in this band
    warm = train.t > 10 * TAU
    rows = np.flatnonzero(warm)[::5]
    taus = TAU * 2.0 ** (np.arange(-4, 5) / 2)
    sel = select_tau(
        factory_for("lpr"),
        [1, 2, 3],
        taus,
        train.delta,
        train.delta_dot,
        train.t,
        train.force,
        rows=rows,
        k=5,
    )
    tau, degree = sel.best
    assert tau == pytest.approx(TAU)
    U = memory_features(train.delta, train.delta_dot, train.t, tau)
    model = LegendreRegression(degree=degree).fit(U[rows], train.force[rows])
    Ut = memory_features(test.delta, test.delta_dot, test.t, tau)
    late = test.t > 10 * TAU
    assert rel_rms(model.predict(Ut[late]), test.force[late]) < 0.01
    # the passive fit of the same features is as good (the element is passive)
    passive = PassiveLegendreRegression(degree=degree).fit(U[rows], train.force[rows])
    assert rel_rms(passive.predict(Ut[late]), test.force[late]) < 0.01
    # best static maps of (δ, δ̇): none goes below the analytic spread
    Us = memory_features(train.delta, train.delta_dot, train.t, form="static")
    Uts = memory_features(test.delta, test.delta_dot, test.t, form="static")
    for deg in (1, 3, 6):
        static = LegendreRegression(degree=deg).fit(Us[rows], train.force[rows])
        err = rel_rms(static.predict(Uts[late]), test.force[late])
        assert err > 0.98 * spread  # 2 %: finite record, not exactly Gaussian


def test_select_tau_table_and_errors():
    m = Maxwell(3, duration=1.0)
    sel = select_tau(factory_for("lpr"), [1], [0.5 * TAU, TAU], m.delta, m.delta_dot, m.t, m.force)
    assert [r["tau"] for r in sel.table] == [0.5 * TAU, TAU]
    assert "<- best" in sel.format()
    with pytest.raises(ValueError, match="tau"):
        maxwell_state(m.delta, m.t, 0.0)
    with pytest.raises(ValueError, match="tau is required"):
        memory_features(m.delta, m.delta_dot, m.t)
    with pytest.raises(ValueError, match="form"):
        memory_features(m.delta, m.delta_dot, m.t, TAU, form="lagged")
    with pytest.raises(ValueError, match="delta"):
        maxwell_state(m.delta[:-1], m.t, TAU)
    assert memory_features(m.delta, m.delta_dot, m.t, TAU).shape[1] == len(FEATURE_FORMS["maxwell"])
