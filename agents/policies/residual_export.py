"""The classical base of a residual policy (:mod:`agents.controllers.residual`) as a linear discrete
state-space controller, for the FMU and the ONNX graph of :mod:`agents.policies.policy_fmu`.

Every exportable base is written in one form, evaluated once per control step on the
physical observation ``y = obs · obs_scale`` (SI; ``obs`` the env's float32 observation),
as the Python controller's ``predict`` does:

    e  = y − C·x⁻ − D·u⁻                    innovation (only with states)
    x̂  = x⁻ + M·e                           measurement update
    F  = clip(G·y − K·x̂, −f_max, f_max)     force, N
    a  = float32(clip(F / f_max, −1, 1))     the controller's action
    x⁻ ← Φ·x̂ + Γ·F,  u⁻ ← F                 the state for the next step

* ``lqg`` (:class:`agents.controllers.lqg.LQG`, :class:`agents.controllers.lqg.VehicleLQG`): the
  steady-state
  Kalman filter and the LQR gain on the estimate (``G = 0``; ``lq-preview``,
  :class:`agents.controllers.preview.LQGPreview`: ``G`` its preview feed-forward, the filter blind
  to the preview channels). Its state ``[x⁻, u⁻]`` starts
  at rest (zeros), as the Python estimate does at an episode start.
* the memoryless bases linear in the observation (``passive``, ``skyhook``, ``groundhook``,
  ``lqr``; the vehicle's ``skyhook``, ``modal-skyhook``, ``lqr``): no states, ``G`` the gain
  of their force (N per SI unit), read at unit observations and checked on random ones.

A base whose force is not linear in the observation (``semi-active``) is refused, naming it.
The residual sum ``clip(a + scale·clip(a_policy, −1, 1), −1, 1)`` is done by the caller.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.controllers.lqg import KalmanFilter

__all__ = ["LinearBase", "base_lines", "base_onnx_nodes", "linear_base"]

#: why a known base cannot be exported (its force is not linear in the observation)
NOT_LINEAR = {
    "semi-active": "it applies the skyhook force only where ẋ2·(ẋ2 − ẋ1) > 0, a switching "
    "law, not a linear function of the observation",
}
#: relative tolerance of the linearity check of a memoryless base
LINEAR_RTOL = 1e-9


@dataclass(frozen=True)
class LinearBase:
    """A residual policy's classical base as a linear discrete state-space (module
    docstring); matrices in SI (N, m, m/s, m/s²), the states' units those of the model."""

    name: str  #: its ``railgym evaluate`` name (``residual`` of the config)
    c: np.ndarray  #: (n_obs, n_x) measurement matrix
    d: np.ndarray  #: (n_obs, n_act) feedthrough of the last force, per N
    m: np.ndarray  #: (n_x, n_obs) Kalman gain
    k: np.ndarray  #: (n_act, n_x) state-feedback gain, N per state unit
    g: np.ndarray  #: (n_act, n_obs) observation gain, N per SI unit
    phi: np.ndarray  #: (n_x, n_x) state transition over one control step
    gamma: np.ndarray  #: (n_x, n_act) input matrix over one control step, per N
    f_max: float  #: force at action 1, N
    obs_scale: np.ndarray  #: SI value of one observation unit per channel
    scale: float  #: weight of the policy's action (``residual_scale``)

    @property
    def n_x(self) -> int:
        """Number of controller states (0: memoryless)."""
        return int(self.phi.shape[0])

    def document(self) -> dict[str, Any]:
        """The matrices as JSON-ready lists (the FMU's ``policy.json``)."""
        keys = ("c", "d", "m", "k", "g", "phi", "gamma")
        doc: dict[str, Any] = {key: getattr(self, key).tolist() for key in keys}
        return {**doc, "name": self.name, "f_max": self.f_max, "scale": self.scale}


def _refuse(name: str, ctrl: Any, why: str) -> ValueError:
    return ValueError(
        f"residual controller {name!r} ({type(ctrl).__name__}) cannot be exported: {why}; "
        "the FMU runs linear state-space controllers only (lqg, lqr, skyhook, groundhook, "
        "modal-skyhook, passive)"
    )


def _gain(ctrl: Any, name: str, n_obs: int, n_act: int, scale: np.ndarray) -> np.ndarray:
    """``G`` (n_act, n_obs), N per SI unit, of a memoryless base whose action (``F / f_max``
    before clipping) is ``G·y / f_max``; ValueError where it is not."""
    zero = np.asarray(ctrl.action(np.zeros((1, n_obs))), float).reshape(1, n_act)
    if np.any(zero != 0.0):
        raise _refuse(name, ctrl, f"its action at a zero observation is {zero[0].tolist()}")
    g = np.asarray(ctrl.action(np.eye(n_obs)), float).reshape(n_obs, n_act).T
    probe = np.random.default_rng(0).normal(0.0, 1.0, (64, n_obs)) * scale
    got = np.asarray(ctrl.action(probe), float).reshape(64, n_act)
    want = probe @ g.T
    if not np.allclose(got, want, rtol=LINEAR_RTOL, atol=LINEAR_RTOL * np.max(np.abs(want))):
        raise _refuse(name, ctrl, "its action is not a linear function of the observation")
    return g * float(ctrl.f_max)


def linear_base(ctrl: Any, name: str, scale: float) -> LinearBase:
    """:class:`LinearBase` of the controller ``ctrl`` (built as :func:`agents.controllers.
    build_controller` does, named ``name``) with residual weight ``scale``; ValueError naming
    the controller and why it cannot be exported."""
    if name in NOT_LINEAR:
        raise _refuse(name, ctrl, NOT_LINEAR[name])
    for attr in ("obs_names", "obs_scale", "f_max", "n_act"):
        if not hasattr(ctrl, attr):
            raise _refuse(name, ctrl, f"it is not an observation-feedback controller (no {attr!r})")
    n_obs, n_act = len(ctrl.obs_names), int(ctrl.n_act)
    obs_scale = np.asarray(ctrl.obs_scale, float)
    kf = getattr(ctrl, "kf", None)
    if isinstance(kf, KalmanFilter):  # the LQG: filter and gain, G its feed-forward
        k = np.asarray(ctrl.K, float)
        g = np.asarray(ctrl.feedforward(np.eye(n_obs)), float).T  # lq-preview's; else 0
        n_s = kf.c.shape[0]  # the filter measures the first channels (not a track preview)
        c, d, m = (
            np.zeros((n_obs, kf.c.shape[1])),
            np.zeros((n_obs, n_act)),
            np.zeros((kf.M.shape[0], n_obs)),
        )
        c[:n_s], d[:n_s], m[:, :n_s] = kf.c, kf.d, kf.M
        phi, gamma = np.asarray(kf.phi, float), np.asarray(kf.gamma, float)
    elif callable(getattr(ctrl, "action", None)):
        g = _gain(ctrl, name, n_obs, n_act, obs_scale)
        c, d, m = np.zeros((n_obs, 0)), np.zeros((n_obs, n_act)), np.zeros((0, n_obs))
        k, phi, gamma = np.zeros((n_act, 0)), np.zeros((0, 0)), np.zeros((0, n_act))
    else:
        raise _refuse(name, ctrl, "it has neither a Kalman filter nor an observation law")
    for key, a in {"c": c, "d": d, "m": m, "k": k, "g": g, "phi": phi, "gamma": gamma}.items():
        if not np.all(np.isfinite(a)):
            raise _refuse(name, ctrl, f"its matrix {key} has non-finite entries")
    return LinearBase(name, c, d, m, k, g, phi, gamma, float(ctrl.f_max), obs_scale, scale)


def _c_doubles(a: np.ndarray) -> str:
    return ", ".join(repr(float(x)) for x in np.ravel(a))


def base_lines(b: LinearBase) -> list[str]:
    """Lines of the generated ``element_data.h`` for ``agents/c/linear_base.h``: ``CT_NX``,
    ``PL_RSCALE`` and the row-major matrices (those with a zero size left out)."""
    lines = [
        "#define PL_RESIDUAL 1",
        f"#define PL_RSCALE {b.scale!r}",
        f"#define CT_NX {b.n_x}",
        f"static const double ct_scale[PL_NIN] = {{{_c_doubles(b.obs_scale)}}};",
        f"static const double ct_g[PL_NOUT * PL_NIN] = {{{_c_doubles(b.g)}}};",
    ]
    if b.n_x:
        shapes = {
            "c": "PL_NIN * CT_NX",
            "d": "PL_NIN * PL_NOUT",
            "m": "CT_NX * PL_NIN",
            "k": "PL_NOUT * CT_NX",
            "phi": "CT_NX * CT_NX",
            "gamma": "CT_NX * PL_NOUT",
        }
        for key, size in shapes.items():
            values = _c_doubles(getattr(b, key))
            lines.append(f"static const double ct_{key}[{size}] = {{{values}}};")
    return lines


def base_onnx_nodes(
    b: LinearBase, const: Callable[[str, np.ndarray], str], obs: str
) -> tuple[list[Any], str, str | None]:
    """ONNX nodes of the base on the float32 observation ``obs`` (tensor name): returns the
    nodes, the name of the controller's action (double, the float32 value) and, with states,
    the name of the new state (the graph's input ``controller_state`` is ``[x⁻, u⁻]``, batch
    × (n_x + n_act), zeros at an episode start); ``const(name, array)`` adds an initializer."""
    from onnx import TensorProto, helper

    n_x, n_act = b.n_x, b.g.shape[0]
    node = helper.make_node
    nodes = [
        node("Cast", [obs], ["ct_obs"], to=TensorProto.DOUBLE),
        node("Mul", ["ct_obs", const("ct_scale", b.obs_scale)], ["ct_y"]),
        node("MatMul", ["ct_y", const("ct_gT", np.ascontiguousarray(b.g.T))], ["ct_gy"]),
    ]
    force = "ct_gy"
    state_out = None
    if n_x:
        axis = const("ct_axis", np.array([1], np.int64))
        cut = [const(f"ct_at{k}", np.array([v], np.int64)) for k, v in enumerate((0, n_x))]
        end = const("ct_end", np.array([n_x + n_act], np.int64))
        mat = {
            key: const(f"ct_{key}T", np.ascontiguousarray(getattr(b, key).T))
            for key in ("c", "d", "m", "k", "phi", "gamma")
        }
        nodes += [
            node("Slice", ["controller_state", cut[0], cut[1], axis], ["ct_xp"]),
            node("Slice", ["controller_state", cut[1], end, axis], ["ct_up"]),
            node("MatMul", ["ct_xp", mat["c"]], ["ct_cx"]),
            node("MatMul", ["ct_up", mat["d"]], ["ct_du"]),
            node("Sub", ["ct_y", "ct_cx"], ["ct_e0"]),
            node("Sub", ["ct_e0", "ct_du"], ["ct_e"]),
            node("MatMul", ["ct_e", mat["m"]], ["ct_me"]),
            node("Add", ["ct_xp", "ct_me"], ["ct_xe"]),
            node("MatMul", ["ct_xe", mat["k"]], ["ct_kx"]),
            node("Sub", ["ct_gy", "ct_kx"], ["ct_raw"]),
        ]
        force = "ct_raw"
    f_max = np.full(1, b.f_max)
    nodes += [
        node("Max", [force, const("ct_fmin", -f_max)], ["ct_f0"]),
        node("Min", ["ct_f0", const("ct_fmax", f_max)], ["ct_f"]),
        node("Div", ["ct_f", const("ct_fdiv", f_max)], ["ct_a0"]),
        node("Max", ["ct_a0", const("ct_m1", -np.ones(1))], ["ct_a1"]),
        node("Min", ["ct_a1", const("ct_p1", np.ones(1))], ["ct_a2"]),
        node("Cast", ["ct_a2"], ["ct_a32"], to=TensorProto.FLOAT),
        node("Cast", ["ct_a32"], ["ct_action"], to=TensorProto.DOUBLE),
    ]
    if n_x:
        nodes += [
            node("MatMul", ["ct_xe", mat["phi"]], ["ct_px"]),
            node("MatMul", ["ct_f", mat["gamma"]], ["ct_gf"]),
            node("Add", ["ct_px", "ct_gf"], ["ct_xn"]),
            node("Concat", ["ct_xn", "ct_f"], ["controller_state_out"], axis=1),
        ]
        state_out = "controller_state_out"
    return nodes, "ct_action", state_out
