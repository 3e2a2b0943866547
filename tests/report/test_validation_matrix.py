"""The validation matrix (railgym.report.validation) and the packaged element's passivity."""

from __future__ import annotations

import numpy as np
import pytest

from agents.commands.cli import main
from agents.controllers.classical import LQR, Skyhook
from railgym.envs.vertical.env import VerticalSuspensionEnv
from railgym.parallel import ray_available
from railgym.report.validation import (
    TARGETS,
    _closed_loop,
    check_targets,
    lqr_law,
    seed_of,
    skyhook_law,
    validation_matrix,
)
from railgym.track import class_speed, track_time_input
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate
from surrogates.memory import element_form
from surrogates.passive import PassiveLegendreRegression, passivity_check

VEH = load_vehicle("manchester")


def test_force_laws_equal_the_agents_controllers():
    """The report's skyhook and LQR laws are the agents' controllers (railgym cannot import
    agents): same gain, same force on random states."""
    env = VerticalSuspensionEnv(observation="full", backend="linear")
    x = np.random.default_rng(0).normal(0, [0.01, 0.1, 0.01, 0.1], (20, 4))
    lqr, sky = lqr_law(VEH, env.cfg.f_max), skyhook_law()
    obs = np.zeros((20, len(env.obs_names)))
    obs[:, :4] = x
    np.testing.assert_allclose([lqr(r) for r in x], LQR(env).force(obs), rtol=1e-9)
    np.testing.assert_allclose([sky(r) for r in x], Skyhook(env).force(obs), rtol=1e-12)


def test_closed_loop_with_zero_force_equals_the_compiled_passive_run():
    _, z, zdot = track_time_input(5, 40.0, 2.0, 1e-3, 5)
    model = default_vertical_surrogate()
    rec = simulate("surrogate", VEH, z, zdot, 1e-3, surrogate=model, sample_every=10)
    loop = _closed_loop("surrogate", VEH, z, zdot, lambda x: 0.0, model, 10, 1e-3, 8e3)
    # the same RK4 step compiled at two call sites: equal to rounding
    np.testing.assert_allclose(loop["a2"], rec["a2"][1:], rtol=0, atol=1e-12)
    np.testing.assert_allclose(loop["x2"], rec["x2"][1:], rtol=0, atol=1e-15)


def test_matrix_rows_equal_an_independent_error_computation():
    static = default_vertical_surrogate("static")
    m = validation_matrix({"static": static}, classes=(6,), n_seeds=2, duration=2.0)
    assert {r["controller"] for r in m["rows"]} == {"passive", "skyhook", "LQR"}
    row = next(r for r in m["rows"] if r["controller"] == "passive")
    want = []
    for seed in m["seeds"]:
        _, z, zdot = track_time_input(6, class_speed(6), 2.0, 1e-3, seed)
        ref = simulate("dynamic", VEH, z, zdot, 1e-3, sample_every=10)["a2"][1:]
        sur = simulate("surrogate", VEH, z, zdot, 1e-3, surrogate=static, sample_every=10)
        want.append(np.sqrt(np.mean((sur["a2"][1:] - ref) ** 2) / np.mean(ref**2)))
    np.testing.assert_allclose(row["errors"], want, rtol=1e-12)
    assert row["median"] == pytest.approx(np.median(want)) and row["max"] == max(want)
    assert m["seeds"] == [seed_of(0), seed_of(1)] and 0 not in m["seeds"]  # unseen tracks
    checked = check_targets(m, "static")
    assert [(c["class"], c["controller"]) for c in checked] == [(6, "passive")]
    assert checked[0]["met"] == (
        row["median"] <= dict(((t[0], t[1]), t[3]) for t in TARGETS)[(6, "passive")]
    )


def test_packaged_element_is_passive_on_three_times_its_box():
    """Issue 10: no negative tangent stiffness or damping (nor ∂F/∂ζ) of the packaged element
    on a grid spanning 3× its training box; the bump-stop law it adds has slope ≥ 0."""
    model = default_vertical_surrogate()
    assert isinstance(model, PassiveLegendreRegression)
    assert element_form(model.features_).form == "maxwell"
    check = passivity_check(model, scale=3.0, n=41)
    assert np.all(check["min_slope"] >= 0.0), check["min_slope"]
    assert np.all(check["negative_fraction"] == 0.0)
    d = np.linspace(-0.2, 0.2, 4001)
    from railgym.vehicles.vertical.elements import bump_stop_force

    f = np.array([bump_stop_force(x, VEH.kernel_params()) for x in d])
    assert np.all(np.diff(f) >= 0.0)


def test_the_paper_static_element_is_not_passive():
    """The negative slopes issue 10 measured on the old default (for contrast)."""
    check = passivity_check(default_vertical_surrogate("static"), scale=3.0, n=201)
    assert check["min_slope"].min() < 0.0


def test_matrix_does_not_depend_on_the_number_of_workers():
    memory = default_vertical_surrogate()
    kwargs = {"classes": (4,), "n_seeds": 2, "duration": 1.0}
    serial = validation_matrix({"memory": memory}, **kwargs)
    pooled = validation_matrix({"memory": memory}, **kwargs, workers=2)
    assert pooled == serial  # floats compared exactly, rows in the same order
    assert len(serial["rows"]) == 3  # passive, skyhook and LQR cross the process boundary


def test_paper_cli_refuses_a_ray_address_without_ray(capsys):
    if ray_available():
        pytest.skip("ray is installed")
    assert main(["paper", "--quick", "--address", "auto"]) == 2
    assert "--address" in capsys.readouterr().err
