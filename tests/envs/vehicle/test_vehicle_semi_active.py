"""``VerticalVehicle-v1`` with ``actuator="semi-active"``: a controllable damper per bogie
(:mod:`railgym.vehicles.vehicle.damper`), its commands the action; the force mode unchanged."""

from __future__ import annotations

import hashlib

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from agents.commands.cli import main
from railgym._checks import FieldError

ENV_ID = "railgym/VerticalVehicle-v1"
SEMI = {"actuator": "semi-active"}
#: sha256 of :func:`_force_episode` computed before the semi-active actuator existed
FORCE_EPISODE_SHA256 = {
    "reference": "a8593c7ffc15cd1218eba7b99040f7e74a93864072ccf82f589c3d1eccdcf0e6",
    "surrogate": "01157e500bbbd489ef747fd5c7a7ce72c111b06dc0d64b6e79a526c975c34b2a",
    "preview": "9088405e320c98643e3cabd0533eabb96e45efab93a4cd0d4af4ef9f8ea96375",
}


def _force_episode(backend: str, **kwargs) -> str:
    """sha256 of a seeded 1-s force-mode episode under random actions: observations, rewards,
    actuator forces, floor accelerations and the final state."""
    env = gym.make(ENV_ID, backend=backend, duration=1.0, **kwargs)
    obs, _ = env.reset(seed=11)
    rng = np.random.default_rng(12)
    h = hashlib.sha256(obs.tobytes())
    for _ in range(100):
        obs, rew, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        h.update(obs.tobytes())
        h.update(np.float64(rew).tobytes())
        h.update(np.asarray(info["actuator_force"], np.float64).tobytes())
        h.update(np.asarray(info["carbody_acc"], np.float64).tobytes())
        if term or trunc:
            break
    h.update(env.unwrapped.state.tobytes())
    return h.hexdigest()


@pytest.mark.parametrize("case", list(FORCE_EPISODE_SHA256))
def test_force_mode_is_bit_identical(case):
    kwargs = {"preview": 5.0} if case == "preview" else {}
    backend = "reference" if case == "preview" else case
    assert _force_episode(backend, **kwargs) == FORCE_EPISODE_SHA256[case]


def _rates(env: gym.Env) -> np.ndarray:
    """Extension rates of the front and rear damper ``v_i = ż_b,i − ż_c(x_i)`` (2,), m/s."""
    x, p = env.unwrapped.state, env.unwrapped.vehicle_params
    return np.array(
        [x[10 + 2 * b] - (x[7] + s * p.a * x[8] + p.phi_a * x[9]) for b, s in ((0, 1), (1, -1))]
    )


def test_spaces_and_channels():
    env = gym.make(ENV_ID, backend="linear", preview=2.0, **SEMI)
    names = env.unwrapped.obs_names
    assert env.action_space == gym.spaces.Box(0.0, 1.0, (2,), np.float32)
    assert names[-2:] == ("damper_command_0", "damper_command_1")
    assert names[-3] == "preview_zdot_4"  # the preview channels, then the damper commands
    assert env.observation_space.shape == (len(names),)
    force = gym.make(ENV_ID, backend="linear")
    assert "damper_command_0" not in force.unwrapped.obs_names
    assert force.action_space.low.tolist() == [-1.0, -1.0]


def test_dampers_only_dissipate_at_both_bogies(random_commands):
    """Random commands over 4 s on class 4: every step's power ``F_i·v_i`` is ≥ 0 at both
    bogies, each damper dissipates energy, and it follows its commands (filtered command in
    [0, 1], observed last)."""
    env = gym.make(ENV_ID, backend="reference", track_class=4, duration=4.0, **SEMI)
    powers = []
    for obs, info in random_commands(env, 2):
        powers.append(info["damper_force"] * _rates(env))
        np.testing.assert_array_equal(obs[-2:], info["damper_command"].astype(np.float32))
        np.testing.assert_array_equal(info["damper_force"], info["actuator_force"])
    powers = np.array(powers)
    assert powers.shape == (400, 2) and powers.min() >= 0.0
    energy = powers.sum(axis=0) * env.unwrapped.cfg.control_dt
    assert np.all(energy > 1.0)  # J over 4 s at each bogie


@pytest.mark.parametrize("backend", ["linear", "reference", "surrogate"])
def test_make_and_make_vec_agree_step_for_step(backend, semi_active_vector_equals_singles):
    """The native vector env equals single envs sub-env by sub-env (seeded ``s + i``), with
    track preview and the dampers combined."""
    kw = {"backend": backend, "duration": 0.3, "preview": 2.0, **SEMI}
    keys = ("damper_force", "damper_command", "actuator_force", "carbody_acc")
    infos = semi_active_vector_equals_singles(ENV_ID, kw, 2, keys)
    assert np.abs(infos[-1]["damper_force"]).max() > 10.0  # the dampers work


def _floor_acc(backend: str) -> np.ndarray:
    """Floor accelerations (steps, 3) of a 5-s class-5 episode under commands switching
    between 0 and 1 every 0.2 s, front and rear in opposition."""
    env = gym.make(ENV_ID, backend=backend, duration=5.0, **SEMI)
    env.reset(seed=1000)
    rec = []
    for k in range(500):
        c = float((k // 20) % 2)
        rec.append(env.step(np.array([c, 1.0 - c], np.float32))[4]["carbody_acc"])
    return np.array(rec)


def test_surrogate_follows_the_reference_carbody_acceleration():
    """The surrogate backend (secondary element and damper element) against the reference:
    relative RMS error of each floor acceleration below 10 %."""
    ref, sur = _floor_acc("reference"), _floor_acc("surrogate")
    err = np.linalg.norm(sur - ref, axis=0) / np.linalg.norm(ref, axis=0)
    assert np.all(err < 0.10), err


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"actuator": "foo"}, "actuator"),
        ({"actuator": "semi-active", "damper": "missing"}, "damper"),
        ({"damper": "missing"}, "damper"),  # a damper without the semi-active actuator
        ({"damper_element": "mr_secondary"}, "damper_element"),
    ],
)
def test_bad_arguments_name_the_field(kwargs, field):
    with pytest.raises(FieldError, match=field):
        gym.make(ENV_ID, backend="linear", **kwargs)


def _cli_a_w(capsys) -> dict[str, np.ndarray]:
    """a_w front/centre/rear (m/s²) of each policy row of ``railgym evaluate``'s table."""
    lines = capsys.readouterr().out.splitlines()
    assert "actuator: semi-active (passive: damper command 0)" in lines[0]
    return {
        ln.split()[2]: np.array([float(v) for v in ln.split()[4].split("/")]) for ln in lines[2:]
    }


def test_cli_semi_active_baselines_against_command_0_on_class_5(capsys):
    """``railgym evaluate ... --env vehicle --actuator semi-active``: every baseline runs one
    5-s class-5 episode on the reference; skyhook, on-off skyhook and clipped LQG ride better
    than command 0 over the bogies (skyhook and clipped LQG also at the worst floor point; the
    centre, the bending mode's antinode, may ride worse), groundhook (it damps the bogies)
    worse."""
    argv = ["evaluate", "skyhook-onoff", "skyhook", "groundhook", "clipped-lqg", "--env"]
    opts = ["vehicle", "--actuator", "semi-active", "--backend", "reference"]
    case = ["--track-class", "5", "--episodes", "1", "--duration", "5", "--seed", "1000"]
    # the figures below are of -v1's track of seed 1000 (evaluate's default is now -v3, whose
    # streamed track of that seed is another one: there skyhook-onoff is above passive)
    case += ["--env-version", "1"]
    assert main([*argv, *opts, *case]) == 0
    a_w = _cli_a_w(capsys)
    assert list(a_w) == ["passive", "skyhook", "skyhook-onoff", "groundhook", "clipped-lqg"]
    ends = [0, 2]  # the floor points over the bogies
    passive = a_w["passive"]
    for name in ("skyhook", "skyhook-onoff", "clipped-lqg"):
        assert np.all(a_w[name][ends] < 0.97 * passive[ends]), (name, a_w)
    for name in ("skyhook", "clipped-lqg"):
        assert a_w[name].max() < passive.max(), (name, a_w)  # the worst floor point
    assert np.all(a_w["groundhook"][ends] > passive[ends]), a_w
