"""Packaged crash elements fitted over the envelope: rebuild = packaged file, gym.make loads
them, the surrogate-vs-reference validation matrix."""

from __future__ import annotations

import numpy as np
import pytest

from agents.commands.crash_elements import main
from agents.evaluation.crash_matrix import constant_action_cases, random_action_cases, worst_errors
from railgym.envs.crash.env import TrainCrashEnv, env_surrogate
from railgym.vehicles.crash.elements import (
    FIT_PAYLOADS_T,
    FIT_SCALES,
    FIT_SPEEDS_KMH,
    NODES_PER_CAR,
    envelope_runs,
    packaged_path,
    packaged_surrogate,
    train_key,
    validation_matrix,
)
from railgym.vehicles.crash.fe import load_crash_surrogate
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.scenario import load_scenario
from railgym.vehicles.crash.surrogate import build_crash_surrogate


def _run(env):
    env.reset(seed=0)
    while True:
        *_, term, trunc, info = env.step(np.zeros(2, np.float32))
        if term or trunc:
            return info


@pytest.mark.slow
def test_rebuilding_the_packaged_elements_gives_the_packaged_file(tmp_path):
    """The documented command rebuilds the file: same fit, same forces on a dense grid (60
    reference runs, cross-validated pieces)."""
    assert main(["--scenario", "paper", "--out", str(tmp_path / "e.json")]) == 0
    with pytest.raises(SystemExit):  # an existing file needs --overwrite
        main(["--scenario", "paper", "--out", str(tmp_path / "e.json")])
    sc = load_scenario("paper")
    rebuilt, packaged = load_crash_surrogate(tmp_path / "e.json"), packaged_surrogate(sc)
    assert packaged is not None and packaged.source == "paper"
    assert rebuilt.nodes_per_car == packaged.nodes_per_car == NODES_PER_CAR
    for name, el in packaged.elements.items():
        new = rebuilt.elements[name]
        assert new.degrees == el.degrees
        u = np.linspace(-0.1, 3.0, 2001)[:, None]
        scale = np.max(np.abs(el.loading.predict(u)))
        np.testing.assert_allclose(new.loading.predict(u), el.loading.predict(u), atol=1e-6 * scale)
        assert new.unloading_stiffness == pytest.approx(el.unloading_stiffness, rel=1e-9)
        assert new.tension_stiffness == pytest.approx(el.tension_stiffness, rel=1e-6, abs=1e-6)


def test_envelope_runs_cover_the_grid_and_scale_the_absorbers():
    runs = envelope_runs("paper", speeds_kmh=(40.0,), scales=FIT_SCALES)
    crush = np.array([r.crush.max(axis=0) for r in runs])  # (runs, zones: wall, interface)
    assert crush[0, 0] > crush[1, 0] > crush[2, 0]  # softer absorbers crush further
    # each zone crushes furthest with its own absorber soft and the other stiff
    scales = [r.extra["absorber_scale"] for r in runs]
    assert np.argmax(crush[:, 0]) == scales.index((0.7, 1.3))
    assert np.argmax(crush[:, 1]) == scales.index((1.3, 0.7))
    passive = simulate_reference("paper")  # the batch recorder = the reference recorder
    np.testing.assert_array_equal(runs[1].a[: passive.t.size - 1], passive.a[:-1])
    assert {r.extra["absorber_scale"] for r in runs} == set(FIT_SCALES)
    # a scaled run fitted alone recovers the nominal envelope: force / scale in the stroke
    soft, nominal = (build_crash_surrogate(r).elements["wall"] for r in (runs[0], runs[1]))
    u = np.linspace(0.7, 1.5, 81)[:, None]
    np.testing.assert_allclose(
        soft.loading.predict(u), nominal.loading.predict(u), rtol=0.1
    )  # LPR fits of different data: agree to the folding-wave amplitude


def test_gym_make_loads_the_packaged_elements_for_every_scenario_of_the_train():
    paper = load_scenario("paper")
    key = train_key(paper)
    for name in ("envelope", "speed25", "speed50", "identical_train"):
        sc = load_scenario(name)
        assert train_key(sc) == key
        assert env_surrogate(sc).source == name
    assert train_key(load_scenario("trainset")) != key  # 4 cars: fitted on demand
    assert packaged_surrogate(load_scenario("trainset")) is None
    assert packaged_surrogate(paper, "paper") is None  # only the hysteretic set is packaged
    env = TrainCrashEnv()
    deg = env.model.params.lpr.degree
    elements = packaged_surrogate(paper).elements.values()
    assert list(deg) == [d for e in elements for d in e.loading.degrees]  # one LPR per stage
    assert env.model.masses.size == 2 * NODES_PER_CAR
    assert packaged_path("paper").is_file()


def test_validation_matrix_is_the_envs_physics_and_holds_its_measured_accuracy():
    sc = load_scenario("paper")
    sur = env_surrogate(sc)
    rows = validation_matrix(sc, sur)
    assert [(r.speed_kmh, r.scale) for r in rows][:4] == [
        (25, 0.7),
        (25, 1.0),
        (25, 1.3),
        (32, 0.7),
    ]
    assert len(rows) == 12
    cell = next(r for r in rows if r.speed_kmh == 40 and r.scale == 1.0)
    for backend, peak, crush in (
        ("reference", cell.peak_ref, cell.crush_ref),
        ("surrogate", cell.peak_sur, cell.crush_sur),
    ):
        info = _run(TrainCrashEnv(backend=backend))  # passive env episode at 40 km/h
        np.testing.assert_array_equal(info["peak_decel_g"], peak)
        np.testing.assert_array_equal(info["max_crush_m"], crush)
    # measured (docs/envs/crash.md): wall crush within 2.1 %, car-2 peak within 0.5 %; the
    # lead-car peak and the interface crush miss the 5 % target (up to 12 % / 13 %)
    assert max(abs(r.crush_error[0]) for r in rows) < 0.03
    assert max(abs(r.peak_error[1]) for r in rows) < 0.01
    assert FIT_SPEEDS_KMH[0] == 25.0 and 32.0 not in FIT_SPEEDS_KMH  # 32 km/h is held out


def test_fitting_payloads_are_the_envelopes_extremes():
    env = load_scenario("envelope").envelope
    ranges = env.payload_ranges(2) / 1e3  # (cars, 2) t
    assert FIT_PAYLOADS_T == (tuple(ranges[:, 0]), tuple(ranges[:, 1]))


def test_packaged_elements_hold_on_the_reference_across_actions():
    """Cells of the matrix of docs/envs/crash.md through the vector env on both backends
    (rate-limited absorbers, 1 ms control): the slowest and fastest speed × the lightest and
    heaviest payload × the extreme constant actions, and 4 random action sequences at 40 and
    at 50 km/h. Each car's peak and 10 ms deceleration and each zone's largest crush within
    1 % / 1.5 % (measured on these cells: 0.3 % / 0.4 %; the elements fitted on every sample at
    the largest crush, before plastic flow was required, 1.9 % / 5.9 %; the one-mass elements
    were off by up to 45 % here)."""
    const = constant_action_cases(speeds_kmh=(25.0, 50.0), actions=(-1.0, 1.0))
    assert len(const) == 8 and {c.payload_t for c in const} == {(0.0, 0.0), (2.0, 8.0)}
    for metric, worst in worst_errors(const).items():
        assert np.all(worst < 0.01), metric
    for kmh, seed in ((40.0, 3), (50.0, 2)):
        rand = random_action_cases(speeds_kmh=(kmh,), n_sequences=4, seed=seed)
        assert len({c.payload_t for c in rand}) == 4  # payloads drawn per sequence
        for metric, worst in worst_errors(rand).items():
            assert np.all(worst < 0.015), (kmh, metric)
