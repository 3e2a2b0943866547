"""Physical plausibility where a unit or a regime is easy to get wrong: a crash that crushes a
car through, a profile in millimetres, an element fitted on another problem, a surrogate that
leaves the reference's envelope."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym.envs.crash.step import crush_limits
from railgym.vehicles.crash.scenario import load_scenario


def _run_crash(env) -> tuple[dict, float, int]:
    env.reset(seed=0)
    steps = 0
    while True:
        _, r, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, np.float32))
        steps += 1
        if terminated or truncated:
            return info, float(r), steps


def test_crush_limits_are_the_car_lengths():
    np.testing.assert_allclose(crush_limits(np.array([27.6, 26.0, 26.0])), [27.6, 26.8, 26.0])


@pytest.mark.parametrize("backend", ["surrogate", "reference"])
@pytest.mark.parametrize("kmh", [400.0, 500.0])
def test_a_crash_that_crushes_the_lead_car_through_diverges(backend, kmh):
    env = gym.make("railgym/TrainCrash-v1", speed=kmh / 3.6, backend=backend)
    info, reward, steps = _run_crash(env)
    length = load_scenario("paper").lead.length
    assert info["diverged"] and reward == -100.0
    # it ends on the step that passes the car's length (one 1 ms step at <= 139 m/s: 0.14 m)
    assert length < info["max_crush_m"][0] < length + 0.14
    assert steps < 300  # long before max_duration (2000 steps)


@pytest.mark.parametrize("backend", ["surrogate", "reference"])
def test_a_fast_crash_the_model_holds_does_not_diverge(backend):
    info, _, _ = _run_crash(gym.make("railgym/TrainCrash-v1", speed=150 / 3.6, backend=backend))
    assert not info["diverged"] and info["max_crush_m"][0] < 27.6


@pytest.mark.parametrize(("kmh", "flagged"), [(40.0, False), (450.0, True)])
def test_the_vector_env_flags_a_train_crushed_through(kmh, flagged):
    venv = gym.make_vec(
        "railgym/TrainCrash-v1", num_envs=2, vectorization_mode="vector_entry_point"
    )
    venv.reset(seed=0, options={"speed_kmh": kmh})
    seen = np.zeros(2, bool)
    for _ in range(300):
        _, _, _, _, info = venv.step(np.zeros(venv.action_space.shape, np.float32))
        seen |= info["diverged"]
    assert seen.tolist() == [flagged, flagged]


def _element_file(tmp_path, **document):
    from surrogates import LegendreRegression, io

    u = np.random.default_rng(0).uniform(-1.0, 1.0, (200, 2))  # another problem: [-1, 1]²
    model = LegendreRegression(degree=3).fit(u, u.sum(axis=1))
    return str(io.save(model, tmp_path / "element.json", **document))


@pytest.mark.parametrize("env_id", ["railgym/VerticalSuspension-v1", "railgym/VerticalVehicle-v1"])
@pytest.mark.parametrize(
    ("document", "message"),
    [
        (
            {"inputs": ["d", "v"], "output": "F", "units": {"d": "mm", "v": "m/s", "F": "N"}},
            r"input 'd' has unit 'mm'",
        ),
        (
            {"inputs": ["d", "v"], "output": "F", "units": {"d": "m", "v": "m/s", "F": "kN"}},
            r"output 'F' has unit 'kN'",
        ),
    ],
    ids=["mm", "kN"],
)
def test_an_element_in_other_units_is_refused(tmp_path, env_id, document, message):
    with pytest.raises(ValueError, match=rf"^surrogate .*{message}"):
        gym.make(env_id, surrogate=_element_file(tmp_path, **document))


def test_an_unnamed_element_is_judged_alike_in_memory_and_from_its_file(tmp_path):
    """Without names (``surrogates.build(U, V)``) an element is taken as SI in memory and
    after ``io.save`` → ``io.load``: the same warning of a fit of another problem in both."""
    from surrogates import io

    path = _element_file(tmp_path)
    for surrogate in (io.load(path), path):
        with pytest.warns(UserWarning, match="does not look like"):
            gym.make("railgym/VerticalSuspension-v1", surrogate=surrogate, duration=0.1)


def test_an_element_in_si_units_is_taken(tmp_path):
    units = {"d": "m", "v": "m/s", "F": "N"}
    path = _element_file(tmp_path, inputs=["d", "v"], output="F", units=units)
    with pytest.warns(UserWarning, match="does not look like"):  # taken, but F = u1 + u2
        env = gym.make("railgym/VerticalSuspension-v1", surrogate=path, duration=0.1)
    env.reset(seed=0)


SI = {"d": "m", "v": "m/s", "F": "N"}


def _unrelated_element(tmp_path) -> str:
    """The issue's element: fitted on another problem (domain [−1, 1]², F = sin u1 + u2²)
    and saved with the right units."""
    from surrogates import LegendreRegression, io

    u = np.random.default_rng(0).uniform(-1.0, 1.0, (400, 2))
    model = LegendreRegression(degree=5).fit(u, np.sin(u[:, 0]) + u[:, 1] ** 2)
    return str(io.save(model, tmp_path / "unrelated.json", inputs=["d", "v"], output="F", units=SI))


def _plausibility_warnings(record) -> list[str]:
    return [str(w.message) for w in record if "does not look like" in str(w.message)]


@pytest.mark.parametrize("env_id", ["railgym/VerticalSuspension-v1", "railgym/VerticalVehicle-v1"])
def test_an_element_of_another_problem_is_warned_once_at_construction(tmp_path, env_id):
    """Nothing else flags it (it stays in its box: ``outside_element`` False for 500 steps),
    so construction warns once, naming the element, the vehicle and the measured ratios."""
    path = _unrelated_element(tmp_path)
    with pytest.warns(UserWarning, match="does not look like") as record:
        env = gym.make(env_id, surrogate=path)
    (text,) = _plausibility_warnings(record)
    assert text.startswith(
        f"surrogate {path!r} does not look like the secondary suspension of vehicle "
        "'manchester': dF/dδ = 1 N/m against k2 = 8.6e+05 N/m; dF/dδ̇ = "
    )
    assert "dF/dδ / k2 = 1.16e-06, dF/dδ̇ / c2 = " in text and "both ratios in 0.2–5" in text
    assert "its training box δ ∈ [-0.988, 0.999] m reaches beyond ±0.6 m" in text
    (where,) = [w.filename for w in record if "does not look like" in str(w.message)]
    assert where == __file__  # points at the gym.make line
    import warnings

    with warnings.catch_warnings(record=True) as later:
        warnings.simplefilter("always")
        env.reset(seed=0)
        flagged = False
        for _ in range(500):
            _, _, _, _, info = env.step(np.zeros(env.action_space.shape, np.float32))
            flagged |= bool(np.any(info["outside_element"]))
    assert not flagged and info["out_of_domain"] == 0
    assert _plausibility_warnings(later) == []  # once, at construction


def test_the_vector_env_warns_once(tmp_path):
    path = _unrelated_element(tmp_path)
    with pytest.warns(UserWarning, match="does not look like") as record:
        gym.make_vec(
            "railgym/VerticalSuspension-v1",
            num_envs=3,
            vectorization_mode="vector_entry_point",
            surrogate=path,
        )
    assert len(_plausibility_warnings(record)) == 1


def _packaged(name):
    from railgym.vehicles.collect import build_vertical_surrogate, default_vertical_surrogate
    from railgym.vehicles.vehicle.collect import default_vehicle_surrogate

    if name == "built":  # from the project's data on the packaged vehicle
        return build_vertical_surrogate()[0]
    if name == "vehicle":
        return default_vehicle_surrogate()
    return default_vertical_surrogate(*name.split("-"))


@pytest.mark.parametrize(
    ("env_id", "element"),
    [
        ("railgym/VerticalSuspension-v1", "maxwell"),
        ("railgym/VerticalSuspension-v1", "static"),
        ("railgym/VerticalSuspension-v1", "maxwell-v0"),
        ("railgym/VerticalSuspension-v1", "built"),
        ("railgym/VerticalVehicle-v1", "vehicle"),
        ("railgym/VerticalVehicle-v1", "maxwell"),
        ("railgym/VerticalVehicle-v1", "static"),
    ],
)
def test_the_packaged_and_project_built_elements_are_not_warned(env_id, element):
    import warnings

    model = _packaged(element)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        gym.make(env_id, surrogate=model)
    assert _plausibility_warnings(record) == []


def _stress(backend, track_class, factor, seed, duration=5.0, static=False):
    """Bang-bang run of VerticalVehicle-v1 (``static``: with the paper's static element, the
    issue's stress case); largest secondary deflection (m), the last info and the number of
    steps flagged ``outside_element``."""
    from railgym.track import class_speed
    from railgym.vehicles.collect import default_vertical_surrogate

    element = default_vertical_surrogate("static") if static and backend == "surrogate" else None
    env = gym.make(
        "railgym/VerticalVehicle-v1",
        backend=backend,
        surrogate=element,
        track_class=track_class,
        speed=factor * class_speed(track_class),
        duration=duration,
    )
    env.reset(seed=seed)
    rng, peak, done, flagged = np.random.default_rng(seed), 0.0, False, 0
    sim = env.unwrapped.sim
    while not done:
        _, _, terminated, truncated, info = env.step(rng.choice([-1.0, 1.0], 2).astype(np.float32))
        done = terminated or truncated
        flagged += info["outside_element"]
        x, p = sim.arrays.state[0], sim.params
        for xb in (p.a, -p.a):
            peak = max(peak, abs(x[3 if xb > 0 else 5] - x[0] - xb * x[1] - p.phi_a * x[2]))
    return peak, info, flagged


def test_a_surrogate_excursion_beyond_the_reference_is_flagged():
    peak, info, flagged = _stress("surrogate", 4, 1.9, seed=2, static=True)
    ref_peak, ref_info, ref_flagged = _stress("reference", 4, 1.9, seed=2)
    assert peak > 1.5 * ref_peak  # the stress case: the surrogate leaves the reference
    assert flagged > 0 and ref_flagged == 0
    assert info["outside_envelope"] and not ref_info["outside_envelope"]


def test_a_ride_inside_the_element_is_not_flagged():
    peak, info, flagged = _stress("surrogate", 5, 1.0, seed=0)
    assert flagged == 0 and info["out_of_domain"] == 0 and not info["outside_envelope"]
    lpr = gym.make("railgym/VerticalVehicle-v1").unwrapped.sim.lpr
    assert peak < min(-lpr.lo[0], lpr.up[0])


def test_the_vector_env_flags_per_sub_env():
    from railgym.track import class_speed
    from railgym.vehicles.collect import default_vertical_surrogate

    venv = gym.make_vec(
        "railgym/VerticalVehicle-v1",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        track_class=4,
        speed=1.9 * class_speed(4),
        duration=5.0,
        surrogate=default_vertical_surrogate("static"),
    )
    venv.reset(seed=2)
    rng = np.random.default_rng(2)
    seen = np.zeros(2, bool)
    for _ in range(499):
        _, _, _, _, info = venv.step(rng.choice([-1.0, 1.0], (2, 2)).astype(np.float32))
        assert info["outside_element"].dtype == bool and info["outside_element"].shape == (2,)
        seen |= info["outside_element"]
    np.testing.assert_array_equal(seen, info["out_of_domain"] > 0)
    assert seen.any() and info["outside_envelope"].all()


def _vertical_stress(backend, track_class, factor, seed, static=False, num_envs=None):
    """Bang-bang run of VerticalSuspension-v1 (single env, or the native vector env of
    ``num_envs`` stopped one step before truncation); the range (n, 2) of δ = x1 − x2 (m)
    over the steps, the last info with ``outside_element`` replaced by whether any step had
    it, and the element's training range of δ (m)."""
    from railgym.track import class_speed
    from railgym.vehicles.collect import default_vertical_surrogate

    kwargs = {
        "backend": backend,
        "surrogate": default_vertical_surrogate("static")
        if static and backend == "surrogate"
        else None,
        "track_class": track_class,
        "speed": factor * class_speed(track_class),
        "duration": 5.0,
    }
    if num_envs is None:
        env, shape = gym.make("railgym/VerticalSuspension-v1", **kwargs), (1,)
    else:
        env = gym.make_vec(
            "railgym/VerticalSuspension-v1",
            num_envs=num_envs,
            vectorization_mode="vector_entry_point",
            **kwargs,
        )
        shape = (num_envs, 1)
    env.reset(seed=seed)
    sim, rng = env.unwrapped.sim, np.random.default_rng(seed)
    span = np.array([[np.inf, -np.inf]] * sim.n)
    seen = np.zeros(sim.n, bool)
    for _ in range(sim.cfg.n_steps - 1):
        _, _, _, _, info = env.step(rng.choice([-1.0, 1.0], shape).astype(np.float32))
        seen |= np.asarray(info["outside_element"])
        d = sim.state[:, 0] - sim.state[:, 2]
        span[:, 0], span[:, 1] = np.minimum(span[:, 0], d), np.maximum(span[:, 1], d)
    info["outside_element"] = bool(seen[0]) if num_envs is None else seen
    return span, info, sim.lpr.lo[0], sim.lpr.up[0]


@pytest.mark.parametrize("static", [False, True])
def test_a_vertical_excursion_beyond_the_element_is_flagged(static):
    ((lo, hi),), info, e_lo, e_hi = _vertical_stress("surrogate", 4, 1.9, 2, static)
    assert lo < e_lo or hi > e_hi  # the stress case leaves the element's training range
    assert info["outside_element"] is True
    ((r_lo, r_hi),), ref_info, _, _ = _vertical_stress("reference", 4, 1.9, 2, static)
    assert ref_info["outside_element"] is False
    if static:  # the paper's static element goes 27 % beyond the reference's deflection
        assert max(-lo, hi) > 1.2 * max(-r_lo, r_hi)


@pytest.mark.parametrize("backend", ["reference", "linear"])
def test_the_reference_and_linear_backends_never_flag(backend):
    _, info, _, _ = _vertical_stress(backend, 3, 2.0, 2)
    assert info["outside_element"] is False


def test_a_class_5_ride_inside_the_element_is_not_flagged():
    ((lo, hi),), info, e_lo, e_hi = _vertical_stress("surrogate", 5, 1.0, 0)
    assert e_lo < lo and hi < e_hi
    assert info["outside_element"] is False


def test_the_vertical_vector_env_flags_per_sub_env():
    span, info, e_lo, e_hi = _vertical_stress("surrogate", 4, 1.0, 0, static=True, num_envs=4)
    flags = info["outside_element"]  # any step of each sub-env
    assert flags.dtype == bool and flags.shape == (4,)
    np.testing.assert_array_equal(flags, info["out_of_domain"] > 0)
    # δ left its range at the end of a step: the next step's first stage was outside the box
    assert np.all(flags[(span[:, 0] < e_lo) | (span[:, 1] > e_hi)])
    assert flags.any() and not flags.all()
