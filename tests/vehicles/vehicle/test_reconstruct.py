"""The bogie forces from the floor accelerations (:mod:`railgym.vehicles.vehicle.reconstruct`):
the carbody equations of the whole vehicle inverted, against the forward equations written
out here and against the reference kernel's own secondary forces."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from railgym import _checks as val
from railgym.track import fra_profile_with_slope
from railgym.vehicles.vehicle.model import wheelset_offsets
from railgym.vehicles.vehicle.params import load_whole_vehicle, mode_shape
from railgym.vehicles.vehicle.reconstruct import body_accelerations, bogie_forces
from railgym.vehicles.vehicle.simulate import simulate

WHOLE = load_whole_vehicle("manchester_whole")


def _floor_accelerations(veh, forces, q, q_dot):
    """Floor accelerations front, centre, rear (m/s²) of the carbody under the bogie forces
    ``forces`` (n, 2) N with the bending state ``q`` (m), ``q_dot`` (m/s): the env's
    equations (docs of railgym.vehicles.vehicle.model) evaluated forward."""
    a = veh.bogie_semi_spacing
    total = forces[:, 0] + forces[:, 1]
    z_dd = total / veh.carbody_mass
    th_dd = a * (forces[:, 0] - forces[:, 1]) / veh.carbody_pitch_inertia
    w = 2.0 * math.pi * veh.bending_frequency
    phi_a = float(mode_shape(a, veh.carbody_length))
    q_dd = (
        phi_a * total / veh.bending_modal_mass - 2.0 * veh.bending_damping * w * q_dot - w * w * q
    )
    floor = [
        z_dd + x * th_dd + float(mode_shape(x, veh.carbody_length)) * q_dd for x in (a, 0.0, -a)
    ]
    return np.stack(floor, axis=1), np.stack([z_dd, th_dd, q_dd], axis=1)


@settings(max_examples=60, deadline=None)
@given(
    mass=st.floats(5e3, 6e4),
    inertia=st.floats(1e5, 5e6),
    length=st.floats(10.0, 30.0),
    spacing=st.floats(0.1, 0.45),
    frequency=st.floats(5.0, 15.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_forces_known_to_the_equations_come_back(mass, inertia, length, spacing, frequency, seed):
    """Known bogie forces and any bending state → the floor accelerations of the env's
    equations → the same forces and body accelerations, for any carbody and geometry."""
    veh = dataclasses.replace(
        WHOLE,
        carbody_mass=mass,
        carbody_pitch_inertia=inertia,
        carbody_length=length,
        bogie_semi_spacing=spacing * length,
        bending_frequency=frequency,
    )
    rng = np.random.default_rng(seed)
    forces = rng.normal(0.0, 2e4, (50, 2))
    floor, body = _floor_accelerations(
        veh, forces, rng.normal(0, 1e-3, 50), rng.normal(0, 1e-2, 50)
    )
    got = bogie_forces(floor, veh)
    assert np.allclose(got, forces, rtol=1e-9, atol=1e-9 * np.abs(forces).max())
    assert np.allclose(body_accelerations(floor, veh), body, rtol=1e-9, atol=1e-12)


def test_the_reference_kernels_secondary_forces_come_back():
    """The whole vehicle's reference (air spring with reservoir, Maxwell damper, bump stops;
    passive) on class-5 track: its floor accelerations give its secondary forces, to
    rounding."""
    dt, v, n = 2e-3, 40.0, 500
    _, z, slope = fra_profile_with_slope(5, (n + 600) * v * dt, v * dt, 3)
    rec = simulate(
        "dynamic", WHOLE, z[None], v * slope[None], wheelset_offsets(WHOLE, v, dt), dt, n
    )
    fs = rec["fs"][0]
    assert np.abs(fs).max() > 5e3  # a real ride
    got = bogie_forces(rec["acc"][0, :, :3], WHOLE)
    assert np.abs(got - fs).max() < 1e-9 * np.abs(fs).max()


def test_bogies_at_the_centre_and_bad_shapes_are_refused():
    with pytest.raises(val.FieldError, match="bogie_semi_spacing"):
        bogie_forces(np.zeros((4, 3)), dataclasses.replace(WHOLE, bogie_semi_spacing=0.0))
    with pytest.raises(ValueError, match="3 floor points"):
        bogie_forces(np.zeros((4, 5)), WHOLE)
