"""A controllable (magnetorheological) damper: a normalised Bouc–Wen law with command dynamics.

The law (parameters and sources in ``configs/dampers/*.yaml``)::

    u̇ = η (command − u)                                    command, u ∈ [0, 1]
    ẇ = (v / x_y) (1 − (σ sign(v w) + 1 − σ) |w|ⁿ)          |w| ≤ 1
    F_h = (c_a + c_b u) v + (f_a + f_b u) w
    F = F_h if F_h v > 0 else 0

``v`` is the damper's compression rate (bogie minus carbody velocity, m/s, the vertical
kernels' ``δ̇``) and ``F`` (N) the force it puts on the carbody in the direction of ``v``. The
first three lines are Spencer et al.'s (1997) Bouc–Wen damper with command-dependent
coefficients and a first-order command filter, written in the normalised form of Ikhouane &
Rodellar (2007): ``w = z/z₀`` with ``z₀ = (A/(β + γ))^{1/n}``, ``x_y = z₀/A`` and
``σ = β/(β + γ)``. ``w`` lags a velocity reversal over the pre-yield travel ``x_y``, which gives
the force–velocity loop its hysteresis; with ``σ = 1/2`` and ``n = 2`` it falls linearly from
±1 to 0 over the travel ``x_y`` after a reversal and then follows ``tanh(travel/x_y)``, so
that a long stroke of one sign slides at ``F = (c_a + c_b u) v + (f_a + f_b u) sign(v)``.
``u`` lags the command by ``1/η``.

The last line is the device's passivity, a constraint of this model: the force is cut to 0
where the Bouc–Wen force would supply power, so ``F v ≥ 0`` at every instant (a velocity
reversal at ``|w| > 0`` drops the force to 0 at once; it returns continuously when
``F_h`` changes sign).

The compiled functions are pure and take a :class:`DamperParams`, so the vertical kernels
call them inside each RK4 stage. RK4 keeps ``|w| ≤ 1`` while ``|v|·dt ≤ x_y`` (2 m/s at
``dt`` = 1 ms for ``x_y`` = 2 mm)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym import _checks as val

__all__ = [
    "DAMPER_STATES",
    "DamperParams",
    "checked_history",
    "damper_force",
    "damper_rates",
    "load_damper",
    "simulate_damper",
]

#: states of one damper: filtered command ``u`` and hysteresis variable ``w``
DAMPER_STATES = 2


class DamperParams(NamedTuple):
    """Controllable damper parameters, SI (see the module docstring for the law)."""

    c_a: float  #: viscous slope at command 0, N·s/m
    c_b: float  #: viscous slope added at command 1, N·s/m
    f_a: float  #: yield force at command 0, N
    f_b: float  #: yield force added at command 1, N
    x_y: float  #: pre-yield displacement, m
    sigma: float  #: loop shape (≥ 0.5 keeps |w| ≤ 1)
    n: float  #: sharpness of the yield transition
    eta: float  #: command bandwidth, 1/s


@njit(cache=True, error_model="numpy")
def damper_force(v: float, u: float, w: float, p: DamperParams) -> float:
    """Force on the carbody (N, in the direction of ``v``) at compression rate ``v`` (m/s),
    filtered command ``u`` and hysteresis state ``w``; zero where the law would supply
    power."""
    f = (p.c_a + p.c_b * u) * v + (p.f_a + p.f_b * u) * w
    return f if f * v > 0.0 else 0.0


@njit(cache=True, error_model="numpy")
def damper_rates(v: float, u: float, w: float, command: float, p: DamperParams) -> tuple:
    """Rates ``(u̇, ẇ)`` (1/s) of the damper states at compression rate ``v`` (m/s)."""
    du = p.eta * (command - u)
    s = 1.0 if v * w >= 0.0 else -1.0
    dw = v / p.x_y * (1.0 - (p.sigma * s + 1.0 - p.sigma) * abs(w) ** p.n)
    return du, dw


@njit(cache=True, error_model="numpy")
def _simulate(v, command, dt, p, u0, w0):
    n = v.shape[0]
    force = np.empty(n)
    states = np.empty((n, 2))
    u, w = u0, w0
    for k in range(n):
        states[k, 0] = u
        states[k, 1] = w
        force[k] = damper_force(v[k], u, w, p)
        if k == n - 1:
            break
        va, vb = v[k], v[k + 1]
        vm = 0.5 * (va + vb)
        c = command[k]
        du1, dw1 = damper_rates(va, u, w, c, p)
        du2, dw2 = damper_rates(vm, u + 0.5 * dt * du1, w + 0.5 * dt * dw1, c, p)
        du3, dw3 = damper_rates(vm, u + 0.5 * dt * du2, w + 0.5 * dt * dw2, c, p)
        du4, dw4 = damper_rates(vb, u + dt * du3, w + dt * dw3, c, p)
        u += dt / 6.0 * (du1 + 2.0 * du2 + 2.0 * du3 + du4)
        w += dt / 6.0 * (dw1 + 2.0 * dw2 + 2.0 * dw3 + dw4)
    return force, states


def simulate_damper(
    velocity: np.ndarray,
    command: np.ndarray,
    dt: float,
    params: DamperParams,
    u0: float = 0.0,
    w0: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The damper driven by a compression-rate history (RK4, velocity linear between samples).

    Parameters
    ----------
    velocity : (n,) compression rate at ``t_k = k·dt``, m/s.
    command : (n,) command in [0, 1], held over each step.
    dt : sample step, s.
    params : the damper.
    u0, w0 : initial filtered command and hysteresis state.

    Returns
    -------
    force : (n,) force at each sample, N. states : (n, 2) ``(u, w)`` at each sample.
    """
    v, c, step = checked_history(velocity, command, dt)
    return _simulate(v, c, step, params, float(u0), float(w0))


def checked_history(velocity: Any, command: Any, dt: Any) -> tuple[np.ndarray, np.ndarray, float]:
    """``(velocity, command, dt)`` of a damper run checked: a 1-D compression-rate history
    (m/s), a command in [0, 1] of the same shape, a positive step (s); a bad one raises
    :class:`~railgym._checks.FieldError` naming it."""
    v = val.numeric_array(velocity, "velocity")
    c = val.numeric_array(command, "command", shape=v.shape)
    if v.ndim != 1:
        raise val.FieldError("velocity", f"must be one-dimensional, got shape {v.shape}")
    if c.size and (c.min() < 0.0 or c.max() > 1.0):
        raise val.FieldError("command", "must lie in [0, 1]")
    return v, c, val.positive(dt, "dt")


def load_damper(name_or_path: str | Path = "mr_secondary") -> DamperParams:
    """A damper from a packaged name (``"mr_secondary"``) or a ``.yaml`` path; errors name the
    file and the field (``damper.x_y``)."""
    text, source = val.resolve_yaml(name_or_path, "damper", "railgym", ("configs", "dampers"))
    try:
        top = val.Fields(val.load_yaml(text, source), "")
        f = top.section("damper")
        f.text("name")
        params = DamperParams(
            c_a=f.non_negative("c_a", 1e7),
            c_b=f.non_negative("c_b", 1e7),
            f_a=f.non_negative("f_a", 1e7),
            f_b=f.non_negative("f_b", 1e7),
            x_y=f.in_range("x_y", 0.0, 1.0, lo_open=True),
            sigma=f.in_range("sigma", 0.5, 10.0),
            n=f.in_range("n", 1.0, 10.0),
            eta=f.in_range("eta", 0.0, 1e4, lo_open=True),
        )
        f.done()
        top.done()
    except val.FieldError as exc:
        if str(exc).startswith(source):
            raise
        raise type(exc)(exc.field, f"{source}: {exc}", full=True) from None
    if params.c_a + params.c_b + params.f_a + params.f_b <= 0.0 or not math.isfinite(params.eta):
        raise val.FieldError("damper", f"{source}: the damper produces no force", full=True)
    return params
