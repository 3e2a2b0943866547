"""Passive runs of whole vehicles over sampled track inputs (:func:`simulate`): the batch
kernel :func:`~railgym.vehicles.vehicle.model.advance` driven sample by sample, for tests and
data."""

from __future__ import annotations

from typing import Any

import numpy as np

from railgym.vehicles.vehicle.model import (
    advance,
    check_variant,
    kernel_params,
    lpr_arrays,
    new_arrays,
)
from railgym.vehicles.vehicle.params import WholeVehicle

__all__ = ["simulate"]


def simulate(
    variant: str,
    vehicle: WholeVehicle,
    z: Any,
    zdot: Any,
    offsets: Any,
    dt: float,
    n_steps: int,
    sample_every: int = 1,
    surrogate: Any = None,
    flexible: bool = True,
) -> dict[str, np.ndarray]:
    """Simulate vehicles over sampled track inputs (passive; for tests and data).

    Parameters
    ----------
    z, zdot : (n, M) track height (m) and rate (m/s) on the rear wheelset's grid ``k·dt``.
    offsets : (n, 4) or (4,) wheelset sample offsets
        (:func:`~railgym.vehicles.vehicle.model.wheelset_offsets`).
    n_steps : number of recorded intervals of ``sample_every`` RK4 steps of ``dt`` (s).

    Returns
    -------
    dict
        ``acc`` (n, n_steps, 5) floor points front/centre/rear and bogies, m/s²;
        ``states`` (n, n_steps, s); ``fs`` (n, n_steps, 2) N; ``contacts``, ``out_of_domain``
        (n,) totals; ``diverged`` (n,) bool.
    """
    kind = check_variant(variant)
    z = np.atleast_2d(np.asarray(z, dtype=float))
    zdot = np.atleast_2d(np.asarray(zdot, dtype=float))
    n = z.shape[0]
    lpr = lpr_arrays(surrogate if variant == "surrogate" else None, float(dt))
    arrays, out = new_arrays(n, variant, z.shape[1], lpr)
    arrays.z[:] = z
    arrays.zdot[:] = zdot
    arrays.off[:] = np.broadcast_to(np.asarray(offsets, dtype=float), (n, 4))
    params = kernel_params(vehicle, flexible)
    suspension_record = vehicle.suspension.kernel_params().record()
    acc = np.zeros((n, n_steps, 5))
    states = np.zeros((n, n_steps, arrays.state.shape[1]))
    fs = np.zeros((n, n_steps, 2))
    totals = np.zeros((n, 2), np.int64)
    div = np.zeros(n, np.bool_)
    for m in range(n_steps):
        advance(kind, arrays, sample_every, float(dt), params, suspension_record, lpr, out)
        arrays.k[:] += sample_every
        acc[:, m], states[:, m], fs[:, m] = out.acc, arrays.state, out.fs
        totals += out.count
        div |= out.div
    return {
        "acc": acc,
        "states": states,
        "fs": fs,
        "contacts": totals[:, 0],
        "out_of_domain": totals[:, 1],
        "diverged": div,
    }
