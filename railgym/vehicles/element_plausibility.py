"""Whether a surrogate element looks like the secondary suspension of the vehicle it is run in.

An element fitted on another problem (another vehicle, a test function, data in other units
labelled SI) passes every check of its file and runs in the compiled kernels; nothing flags
it (its inputs stay in its training box, ``outside_element`` stays False). Two measurements
tell such an element from one built for the vehicle:

* its **linearisation at the static equilibrium** ``δ = δ̇ = 0`` (and ``ζ = 0`` for a memory
  element): the tangent stiffness ``∂F̂/∂δ`` against the vehicle's linearised ``k2`` and the
  damping ``∂F̂/∂δ̇`` against ``c2``. For a memory element (``u = (δ, δ̇, ζ)``) the damping is
  its low-frequency value ``∂F̂/∂δ̇ + ∂F̂/∂ζ / g'(0)`` (``ζ`` follows ``δ̇ / g'(0)`` for slow
  motion: ``g'(0) = 1/τ`` for the linear law, the mean of the two segment slopes at 0 for a
  relaxation law). The slopes are central differences of ``predict`` over
  :data:`STEP` of the box width at the equilibrium (at the nearest point of the box, one-sided
  at its faces, when the equilibrium lies outside it); no extrapolation is involved and the
  model's ``n_out_of_domain_`` is not changed. A ratio outside :data:`PLAUSIBLE_RATIO`
  (0.2–5) is reported; ``c2 = 0`` (an undamped vehicle) has no damping ratio;
* its **training box** against the deflections the vehicle can reach: the box must contain
  the equilibrium, reach no further than :data:`REACH_FACTOR` × the vehicle's free travel in
  ``δ`` (:data:`~railgym.vehicles.vertical.params.DEFLECTION_SCALE` for a vehicle without one)
  and :data:`MAX_RATE` in ``δ̇``, and span at least :data:`MIN_SPAN` in each.

:func:`element_plausibility` measures, :func:`implausible_element_warning` gives the text of
the one warning the envs raise at construction (docs/envs/vertical.md, *Element
plausibility*). Known physics the kernel adds (the bump-stop law beyond the free travel) is
zero at the equilibrium and is not part of the measurement.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from railgym.vehicles.vertical.params import DEFLECTION_SCALE
from surrogates.memory import MEMORY_FORMS, element_form

__all__ = [
    "MAX_RATE",
    "MIN_SPAN",
    "PLAUSIBLE_RATIO",
    "REACH_FACTOR",
    "STEP",
    "Plausibility",
    "element_plausibility",
    "implausible_element_warning",
]

#: band of ``∂F̂/∂δ / k2`` and ``∂F̂/∂δ̇ / c2`` of a plausible element, bounds included
PLAUSIBLE_RATIO = (0.2, 5.0)
#: the training box of ``δ`` may reach this many free travels from the equilibrium
REACH_FACTOR = 10.0
#: the training box of ``δ̇`` may reach this far from the equilibrium, m/s
MAX_RATE = 10.0
#: smallest width of the training box in ``δ`` (m) and ``δ̇`` (m/s)
MIN_SPAN = 1e-3
#: finite-difference step of the slopes, fraction of the box width
STEP = 1e-4


class Plausibility(NamedTuple):
    """What :func:`element_plausibility` measured (SI)."""

    stiffness: float  #: ∂F̂/∂δ at the equilibrium, N/m
    damping: float  #: ∂F̂/∂δ̇ at the equilibrium (memory element: low-frequency), N·s/m
    k2: float  #: the vehicle's linearised secondary stiffness, N/m
    c2: float  #: the vehicle's linearised secondary damping, N·s/m
    at: tuple[float, ...]  #: the point of the slopes (the equilibrium, or the box's nearest)
    findings: tuple[str, ...]  #: each implausibility in words; empty: plausible

    @property
    def stiffness_ratio(self) -> float:
        """``∂F̂/∂δ / k2``."""
        return self.stiffness / self.k2

    @property
    def damping_ratio(self) -> float:
        """``∂F̂/∂δ̇ / c2`` (``nan`` for ``c2 = 0``)."""
        return self.damping / self.c2 if self.c2 > 0 else math.nan

    @property
    def plausible(self) -> bool:
        """No finding."""
        return not self.findings


def _slopes(model: Any, at: np.ndarray, lo: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Central (one-sided at a face) differences of ``model.predict`` at ``at`` inside the box
    ``[lo, up]``, output units per input unit, (d,)."""
    count = getattr(model, "n_out_of_domain_", None)
    grad = np.empty(at.size)
    for j in range(at.size):
        h = STEP * (up[j] - lo[j])
        a, b = at.copy(), at.copy()
        a[j], b[j] = max(at[j] - h, lo[j]), min(at[j] + h, up[j])
        f = np.asarray(model.predict(np.stack([a, b])), dtype=float)
        grad[j] = (f[1] - f[0]) / (b[j] - a[j])
    if count is not None:
        model.n_out_of_domain_ = count
    return grad


def _rate_slope(form: Any) -> float:
    """``g'(0)`` of a memory element's relaxation law, 1/s: ``1/τ`` for the linear law, the
    mean of the slopes of the two segments at the knot 0 otherwise (an end segment's slope
    continues beyond an end knot)."""
    if form.relaxation is None:
        return 1.0 / float(form.tau)
    z, r = form.relaxation
    slopes = np.diff(r) / np.diff(z)
    i = int(np.argmin(np.abs(z)))
    left = slopes[i - 1] if i > 0 else slopes[0]
    right = slopes[i] if i < slopes.size else slopes[-1]
    return 0.5 * float(left + right)


def element_plausibility(model: Any, vehicle: Any) -> Plausibility:
    """Linearisation and training box of the fitted element ``model`` (inputs ``δ, δ̇`` or
    ``δ, δ̇, ζ``, force N) against ``vehicle`` (a
    :class:`~railgym.vehicles.vertical.params.VerticalVehicle`, or a whole vehicle with its
    ``suspension``); the measurements and findings of the module docstring."""
    suspension = getattr(vehicle, "suspension", vehicle)
    k2, c2 = float(suspension.k2), float(suspension.c2)
    lo, up = (np.asarray(b, dtype=float) for b in model.domain_)
    form = element_form(getattr(model, "features_", None), lo.size)
    at = np.clip(np.zeros(lo.size), lo, up)
    grad = _slopes(model, at, lo, up)
    stiffness = float(grad[0])
    damping = float(grad[1])
    if form.form in MEMORY_FORMS:
        damping += float(grad[2]) / _rate_slope(form)
    low, high = PLAUSIBLE_RATIO
    findings = []
    if not low <= stiffness / k2 <= high:
        findings.append(f"dF/dδ = {stiffness:.3g} N/m against k2 = {k2:.3g} N/m")
    if c2 > 0 and not low <= damping / c2 <= high:
        findings.append(f"dF/dδ̇ = {damping:.3g} N·s/m against c2 = {c2:.3g} N·s/m")
    travel = [t for t in suspension.travel if math.isfinite(t)]
    reach = REACH_FACTOR * (max(travel) if travel else DEFLECTION_SCALE)
    for j, (name, unit, limit) in enumerate((("δ", "m", reach), ("δ̇", "m/s", MAX_RATE))):
        box = f"its training box {name} ∈ [{lo[j]:.3g}, {up[j]:.3g}] {unit}"
        if not lo[j] <= 0.0 <= up[j]:
            findings.append(f"{box} does not contain the static equilibrium {name} = 0")
        if max(-lo[j], up[j]) > limit:
            findings.append(f"{box} reaches beyond ±{limit:.3g} {unit}")
        if up[j] - lo[j] < MIN_SPAN:
            findings.append(f"{box} is narrower than {MIN_SPAN:g} {unit}")
    return Plausibility(stiffness, damping, k2, c2, tuple(float(v) for v in at), tuple(findings))


def implausible_element_warning(model: Any, vehicle: Any, name: str) -> str | None:
    """The text of the warning for the element ``model`` (called ``name``) in ``vehicle``,
    or ``None`` when it is plausible (:func:`element_plausibility`)."""
    p = element_plausibility(model, vehicle)
    if p.plausible:
        return None
    suspension = getattr(vehicle, "suspension", vehicle)
    ratio = f"dF/dδ / k2 = {p.stiffness_ratio:.3g}"
    if p.c2 > 0:
        ratio += f", dF/dδ̇ / c2 = {p.damping_ratio:.3g}"
    where = "δ = δ̇ = 0" if not any(p.at) else f"the box point {list(p.at)} nearest to it"
    low, high = PLAUSIBLE_RATIO
    return (
        f"surrogate {name} does not look like the secondary suspension of vehicle "
        f"{suspension.name!r}: {'; '.join(p.findings)} ({ratio} at {where}; a plausible "
        f"element has both ratios in {low:g}–{high:g}). It runs, but an element fitted on "
        "another problem, in other units or for another vehicle does not describe this one: "
        "build one for it (railgym collect --vehicle ...; "
        "docs/envs/vertical.md, Element plausibility)."
    )
