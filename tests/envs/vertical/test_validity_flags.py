"""The surrogate's validity flags of both vertical envs (docs/validation.md, *Validity flags*):
``outside_element`` is set for exactly the steps with an element evaluation outside the
training box, counted here independently by replaying each step's RK4 stages in Python from
the env's state; ``outside_envelope`` is the episode's class and speed against the element's
``metadata.envelope``, with one warning per env."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym.track import class_speed
from railgym.vehicles.vehicle.model import N_MECH, _inputs, _rhs, _work, check_variant
from railgym.vehicles.vertical.elements import rhs
from surrogates import io
from surrogates.models.lpr import lpr_scratch

VERTICAL, VEHICLE = "railgym/VerticalSuspension-v3", "railgym/VerticalVehicle-v3"
#: an actuator force that drives the deflection out of the packaged elements' boxes, N
F_BIG = 60000.0


def _outside(u: list[float], lo: np.ndarray, up: np.ndarray) -> int:
    """1 where an element input vector ``u`` leaves the box ``[lo, up]``."""
    v = np.array(u[: lo.size])
    return int(np.any(v < lo) or np.any(v > up))


def _replay_vertical(sim, x0: np.ndarray, k0: int, fa: float) -> tuple[int, np.ndarray]:
    """Out-of-box stage evaluations of one control step of vehicle 0 of a vertical batch from
    state ``x0`` at track sample ``k0`` with actuator force ``fa`` (N), by the kernel's RK4
    (package docstring of :mod:`railgym.vehicles.vertical`) written out here; and its end
    state."""
    lpr, q, dt = sim.lpr, sim.params_record[0], sim.cfg.dt
    z, zd = sim.z[0], sim.zdot[0]
    u, lw = np.empty(lpr.lo.size), lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    r = [np.empty(x0.size) for _ in range(4)]
    x, count = x0.copy(), 0
    for m in range(sim.cfg.n_sub):
        za, zda, zb, zdb = z[k0 + m], zd[k0 + m], z[k0 + m + 1], zd[k0 + m + 1]
        zm = 0.5 * (za + zb) + 0.125 * dt * (zda - zdb)
        zdm = 1.5 / dt * (zb - za) - 0.25 * (zda + zdb)
        stages = [(x.copy(), za, zda)]
        rhs(3, stages[0][0], za, zda, fa, q, lpr, u, lw, r[0])
        for j, (h, zc, zdc) in enumerate(((0.5, zm, zdm), (0.5, zm, zdm), (1.0, zb, zdb))):
            xs = x + h * dt * r[j]
            rhs(3, xs, zc, zdc, fa, q, lpr, u, lw, r[j + 1])
            stages.append((xs, zc, zdc))
        for xs, _, _ in stages:
            d = xs[0] - xs[2]
            count += _outside([d, xs[1] - xs[3], d - xs[4]], lpr.lo, lpr.up)
        x = x + dt / 6.0 * (r[0] + 2.0 * r[1] + 2.0 * r[2] + r[3])
    return count, x


def _replay_vehicle(sim, x0: np.ndarray, k0: int, fa: np.ndarray) -> tuple[int, np.ndarray]:
    """:func:`_replay_vertical` of a whole-vehicle batch: out-of-box evaluations of either
    bogie's element over the stages of one control step (actuator forces ``fa`` (2,), N)."""
    lpr, p, susp, dt = sim.lpr, sim.params, sim.elem[0], sim.cfg.dt
    kind = check_variant("surrogate")
    a = sim.arrays
    z, zd, off, start = a.z[0], a.zdot[0], a.off[0], int(a.start[0])
    wk = _work(x0.size, lpr)
    r = [np.empty(x0.size) for _ in range(4)]
    w, wm = np.empty((4, 2)), np.empty((4, 2))
    x, count = x0.copy(), 0
    _inputs(z, zd, off, float(k0), dt, w, start)
    for m in range(sim.cfg.n_sub):
        t0 = float(k0 + m)
        stages = [x.copy()]
        _rhs(kind, stages[0], w, fa, p, susp, lpr, wk.u, wk.rt, wk.lw, r[0], wk.fs)
        _inputs(z, zd, off, t0 + 0.5, dt, wm, start)
        for j, (h, wheels) in enumerate(((0.5, wm), (0.5, wm), (1.0, w))):
            if j == 2:
                _inputs(z, zd, off, t0 + 1.0, dt, w, start)
            xs = x + h * dt * r[j]
            _rhs(kind, xs, wheels, fa, p, susp, lpr, wk.u, wk.rt, wk.lw, r[j + 1], wk.fs)
            stages.append(xs)
        for xs in stages:
            for b, xb in enumerate((p.a, -p.a)):
                d = xs[3 + 2 * b] - (xs[0] + xb * xs[1] + p.phi_a * xs[2])
                dd = xs[10 + 2 * b] - (xs[7] + xb * xs[8] + p.phi_a * xs[9])
                count += _outside([d, dd, d - xs[N_MECH + b]], lpr.lo, lpr.up)
        x = x + dt / 6.0 * (r[0] + 2.0 * r[1] + 2.0 * r[2] + r[3])
    return count, x


#: the replay reads the whole episode's track arrays of v2 (v3 streams its track: no arrays)
REPLAYED = ("railgym/VerticalSuspension-v2", "railgym/VerticalVehicle-v2")


@pytest.mark.filterwarnings("ignore:.*out of date:DeprecationWarning")
@pytest.mark.parametrize("env_id", REPLAYED)
def test_outside_element_is_set_on_exactly_the_steps_with_out_of_box_evaluations(env_id):
    """A large bang-bang actuator force on class 4 at its maximum speed (inside the
    element's envelope) drives the deflection out of the packaged element's box on some
    steps: each step's flag equals the replayed count > 0, and that count equals the step's
    ``out_of_domain`` increment (the replay reproduces the state bit for bit)."""
    env = gym.make(env_id, track_class=4, f_max=F_BIG, duration=3.0).unwrapped
    _, info = env.reset(seed=1)
    assert info["outside_element"] is False and info["outside_envelope"] is False
    sim, rng = env.sim, np.random.default_rng(0)
    vertical = env_id == REPLAYED[0]
    state, k = (sim.state, sim.k) if vertical else (sim.arrays.state, sim.arrays.k)
    flags, counts, done, before = [], [], False, 0
    while not done:
        x0, k0 = state[0].copy(), int(k[0])
        action = rng.choice([-1.0, 1.0], env.action_space.shape).astype(np.float32)
        _, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
        fa = action.astype(np.float64) * F_BIG
        count, end = (_replay_vertical if vertical else _replay_vehicle)(
            sim, x0, k0, float(fa[0]) if vertical else fa
        )
        np.testing.assert_array_equal(end, state[0])
        assert count == info["out_of_domain"] - before
        before = info["out_of_domain"]
        flags.append(info["outside_element"])
        counts.append(count)
        assert info["outside_envelope"] is False
    assert not terminated and len(flags) == 300
    np.testing.assert_array_equal(flags, np.array(counts) > 0)
    assert 0 < sum(flags) < len(flags) // 2  # some steps leave the box, most do not


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE])
def test_the_vector_env_flags_each_sub_env_per_step(env_id):
    """The lane kernels (8 sub-envs or more): each sub-env's flag is its step's count > 0."""
    venv = gym.make_vec(
        env_id,
        num_envs=8,
        vectorization_mode="vector_entry_point",
        track_class=4,
        f_max=F_BIG,
        duration=1.0,
    )
    _, info = venv.reset(seed=3)
    rng, before, seen = np.random.default_rng(1), np.zeros(8, np.int64), np.zeros(8, bool)
    for _ in range(99):
        action = rng.choice([-1.0, 1.0], venv.action_space.shape).astype(np.float32)
        _, _, _, _, info = venv.step(action)
        assert info["outside_element"].dtype == bool and info["outside_element"].shape == (8,)
        np.testing.assert_array_equal(info["outside_element"], info["out_of_domain"] > before)
        before = info["out_of_domain"].copy()
        seen |= info["outside_element"]
        assert not info["outside_envelope"].any()
    assert seen.any()


def _make(env_id, track_class, factor, backend="surrogate", **kwargs):
    return gym.make(
        env_id,
        backend=backend,
        track_class=track_class,
        speed=factor * class_speed(track_class),
        duration=0.1,
        **kwargs,
    )


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE])
def test_outside_envelope_is_the_episodes_and_warns_once_per_env(env_id):
    env = _make(env_id, 3, 1.5)
    with pytest.warns(UserWarning, match=r"built for FRA classes 3, 4, 5, 6 .* class 3 at 40 m/s"):
        _, info = env.reset(seed=0)
    assert info["outside_envelope"] is True
    for _ in range(10):
        *_, info = env.step(np.zeros(env.action_space.shape, np.float32))
        assert info["outside_envelope"] is True
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, info = env.reset(seed=1)  # the same env: no second warning
        assert info["outside_envelope"] is True
        _, info = env.reset(seed=1, options={"track_class": 5})  # class 5 at its speed
        assert info["outside_envelope"] is False
        inside = _make(env_id, 4, 1.0)
        _, info = inside.reset(seed=0)
        assert info["outside_envelope"] is False


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE])
@pytest.mark.parametrize("backend", ["reference", "linear"])
def test_the_high_fidelity_and_linear_backends_are_never_outside(env_id, backend):
    env = _make(env_id, 2, 2.0, backend=backend)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, info = env.reset(seed=0)
    *_, info = env.step(np.zeros(env.action_space.shape, np.float32))
    assert info["outside_envelope"] is False and info["outside_element"] is False


def test_the_envelope_ends_at_each_bound():
    """vertical_lpr.json: classes 3-6 at 0.7-1.0 of each class's maximum speed."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        for tc, factor, outside in [
            (3, 0.7, False),
            (6, 1.0, False),
            (3, 0.69, True),
            (6, 1.01, True),
            (2, 1.0, True),
        ]:
            _, info = _make(VERTICAL, tc, factor).reset(seed=0)
            assert info["outside_envelope"] is outside, (tc, factor)


def test_a_drawn_speed_decides_each_vehicle_episode():
    """VerticalVehicle-v1 with a speed range: the flag follows each episode's drawn speed
    (the packaged whole-vehicle element: at most each class's maximum speed, 60-200 km/h)."""
    v_max = class_speed(4)
    venv = gym.make_vec(
        VEHICLE,
        num_envs=16,
        vectorization_mode="vector_entry_point",
        track_class=4,
        speed=(0.8 * v_max, 1.2 * v_max),
        duration=0.1,
    )
    with pytest.warns(UserWarning, match="outside that envelope"):
        _, info = venv.reset(seed=0)
    np.testing.assert_array_equal(info["outside_envelope"], info["speed"] > v_max)
    assert info["outside_envelope"].any() and not info["outside_envelope"].all()


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE])
def test_a_measured_profile_is_outside_the_envelope(env_id):
    x = np.linspace(0.0, 500.0, 5001)
    profile = (x, 1e-3 * np.sin(2 * np.pi * x / 20.0))
    env = _make(env_id, 5, 1.0)
    with pytest.warns(UserWarning, match="measured or user profile"):
        _, info = env.reset(seed=0, options={"profile": profile})
    assert info["outside_envelope"] is True


def test_reset_on_track_takes_the_other_envs_case():
    from railgym.envs.vertical.env import VerticalSuspensionEnv

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        fast = VerticalSuspensionEnv(track_class=3, speed=1.5 * class_speed(3), duration=0.1)
        fast.reset(seed=0)
        other = VerticalSuspensionEnv(track_class=3, speed=1.5 * class_speed(3), duration=0.1)
        other.reset(seed=0)
        other.reset(seed=0, options={"speed": class_speed(3)})
        assert other.sim.info(0)["outside_envelope"] is False
        other.reset_on_track(fast)
    assert other.sim.info(0)["outside_envelope"] is True


def _element_file(tmp_path, envelope):
    from surrogates import LegendreRegression

    u = np.random.default_rng(0).uniform([-0.03, -0.3], [0.03, 0.3], (200, 2))
    model = LegendreRegression(degree=1).fit(u, 1e6 * u[:, 0] + 1e4 * u[:, 1])
    units = {"d": "m", "v": "m/s", "F": "N"}
    metadata = {} if envelope is None else {"envelope": envelope}
    path = tmp_path / "element.json"
    io.save(model, path, inputs=["d", "v"], output="F", units=units, metadata=metadata)
    return str(path)


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE])
def test_an_element_without_an_envelope_is_never_outside(tmp_path, env_id):
    env = _make(env_id, 2, 2.0, surrogate=_element_file(tmp_path, None))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, info = env.reset(seed=0)
    assert info["outside_envelope"] is False


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE])
def test_a_users_envelope_in_absolute_speeds_is_read(tmp_path, env_id):
    path = _element_file(tmp_path, {"track_classes": [4], "speed": [30.0, 36.0]})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, info = _make(env_id, 4, 1.0, surrogate=path).reset(seed=0)  # 35.6 m/s
    assert info["outside_envelope"] is False
    with pytest.warns(UserWarning, match=r"FRA class 4 at 30–36 m/s"):
        _, info = _make(env_id, 4, 1.05, surrogate=path).reset(seed=0)
    assert info["outside_envelope"] is True


@pytest.mark.parametrize(
    ("envelope", "message"),
    [
        ({"speed_factor": [0.5, 1.0]}, r"metadata\.envelope\.track_classes must be a non-empty"),
        ({"track_classes": [7]}, r"metadata\.envelope\.track_classes must be a non-empty"),
        ({"track_classes": [5], "speed_factor": [1.0, 0.5]}, r"speed_factor must have 0 <= low"),
        ({"track_classes": [5], "speed": [30]}, r"metadata\.envelope\.speed must be \[low, high\]"),
        ({"track_classes": [5], "speeds": [30, 40]}, r"envelope\.speeds is not a known field"),
        ([5], r"metadata\.envelope must be an object"),
    ],
)
def test_a_malformed_envelope_is_refused_naming_the_field(tmp_path, envelope, message):
    with pytest.raises(ValueError, match=rf"^surrogate .*{message}"):
        gym.make(VERTICAL, surrogate=_element_file(tmp_path, envelope))
