"""Fixtures shared by the vehicle tests: the packaged whole vehicle and the check that the
lane kernel equals the per-vehicle kernel."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from railgym.vehicles.vehicle.model import (
    Lpr,
    advance,
    advance_serial,
    check_variant,
    kernel_params,
    new_arrays,
    wheelset_offsets,
)
from railgym.vehicles.vehicle.params import WholeVehicle, load_whole_vehicle

#: vehicle speed of the kernel comparison, m/s
SPEED = 40.0


@pytest.fixture(scope="session")
def vehicle() -> WholeVehicle:
    """The packaged whole vehicle."""
    return load_whole_vehicle()


@pytest.fixture
def assert_lanes_match_serial() -> Callable[[WholeVehicle, Lpr, int, float], list[np.ndarray]]:
    """``check(vehicle, lpr, n, dt)``: ``n`` surrogate vehicles with the element ``lpr``,
    seeded random tracks (vehicle 5 on an impossible step, so that it diverges) and actuator
    forces, four steps of 25 samples by ``advance`` (the lane kernel, serial below
    ``PARALLEL_MIN``, on all threads above) and by ``advance_serial``: bit-identical states and
    outputs, with bump-stop contact, element inputs outside the box and the divergence seen.
    Returns the rows of ``advance_serial`` (after each step: the state, then the outputs)."""

    def check(vehicle: WholeVehicle, lpr: Lpr, n: int, dt: float) -> list[np.ndarray]:
        off = wheelset_offsets(vehicle, SPEED, dt)
        n_sub = 25
        samples = int(off.max()) + 4 * n_sub + 2
        rng = np.random.default_rng(n)
        z = rng.uniform(5e-3, 4e-2, (n, 1)) * np.cumsum(rng.standard_normal((n, samples)), axis=1)
        z[5, 1:] = 50.0  # an impossible step: this vehicle diverges
        force = rng.uniform(-2e4, 2e4, (n, 2))
        p = kernel_params(vehicle)
        e = vehicle.suspension.kernel_params().record()
        runs = []
        for step in (advance_serial, advance):
            bt, out = new_arrays(n, "surrogate", samples, lpr)
            bt.z[:], bt.zdot[:] = z, np.gradient(z, dt, axis=1)
            bt.off[:] = off
            bt.force[:] = force
            rows = []
            for _ in range(4):
                step(check_variant("surrogate"), bt, n_sub, dt, p, e, lpr, out)
                bt.k[:] += n_sub
                rows += [bt.state.copy(), *(a.copy() for a in out)]
            runs.append(rows)
        for a, b in zip(*runs, strict=True):
            np.testing.assert_array_equal(a, b)
        counts = sum(runs[0][3::5])
        assert counts[:, 0].sum() > 0 and counts[:, 1].sum() > 0  # contact and extrapolation
        assert runs[0][-1][5] and not runs[0][-1][4]
        return runs[0]

    return check
