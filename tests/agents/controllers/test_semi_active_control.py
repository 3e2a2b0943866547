"""Semi-active baselines: the damper's inverse, the switching laws, the env runs, the names of
``railgym evaluate --actuator`` and the bump-stop contacts of every results table."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from agents.commands.cli import main
from agents.controllers.classical import Skyhook
from agents.controllers.control_base import default_c_sky
from agents.controllers.lqg import LQG
from agents.controllers.registry import CONTROLLERS, SEMI_ACTIVE_BASELINES, baselines_of
from agents.controllers.semi_active_control import (
    SEMI_ACTIVE_CONTROLLERS,
    ClippedLQG,
    DamperSkyhook,
    OnOffSkyhook,
    damper_command,
    steady_force,
)
from agents.evaluation.benchmark import held_out, summary_table
from agents.evaluation.evaluate import format_rows, format_vehicle_rows
from agents.evaluation.gap import format_gap
from agents.evaluation.runs import run_policy
from agents.policies.loading import load_policy
from railgym.vehicles.semi_active import damper_force, load_damper, simulate_damper

ID = "railgym/VerticalSuspension-v1"
DAMPER = load_damper()


def test_the_command_of_a_reachable_demand_gives_it_at_steady_state():
    """Inside the damper's range at ``v`` the command's force, integrated through the Bouc–Wen
    and command dynamics until they settle, is the demand."""
    p = DAMPER
    for v in (-0.3, -0.05, -0.004, 0.01, 0.12):
        soft = p.c_a * abs(v) + p.f_a
        hard = (p.c_a + p.c_b) * abs(v) + p.f_a + p.f_b
        for share in (0.0, 0.2, 0.5, 0.9, 1.0):
            demand = np.sign(v) * (soft + share * (hard - soft))
            u = float(damper_command(demand, v, p))
            assert u == pytest.approx(share, abs=1e-12)
            # the law's own force at u and w = sign(v)
            assert damper_force(v, u, np.sign(v), p) == pytest.approx(demand, rel=1e-12)
            # the dynamics settle there: w = tanh(|v|·t/x_y) after a stroke of 12 x_y, and u
            # within 50 time constants 1/η
            n = round(max(12.0 * p.x_y / abs(v), 50.0 / p.eta) / 1e-4) + 1
            force, _ = simulate_damper(np.full(n, v), np.full(n, u), 1e-4, p)
            assert force[-1] == pytest.approx(demand, rel=1e-6)


def test_a_demand_that_asks_for_power_gets_command_0_and_every_command_lies_in_0_1():
    p = DAMPER
    v = np.array([0.1, -0.1, 0.02, 0.0])
    # opposing the extension rate (the damper would have to supply power), or at rest
    np.testing.assert_array_equal(damper_command([-500.0, 500.0, -1.0, 300.0], v, p), 0.0)
    # below the softest force the nearest is 0, above the hardest 1
    np.testing.assert_array_equal(damper_command([100.0, -100.0], v[:2], p), 0.0)
    np.testing.assert_array_equal(damper_command([1e5, -1e5], v[:2], p), 1.0)
    rng = np.random.default_rng(0)
    demand, rate = rng.normal(0, 5e3, 1000), rng.normal(0, 0.2, 1000)
    u = damper_command(demand, rate, p)
    assert np.all((u >= 0.0) & (u <= 1.0))
    # nearest: no other command's force is closer to the demand
    grid = np.linspace(0.0, 1.0, 101)
    best = np.abs(steady_force(rate[:, None], grid[None, :], p) - demand[:, None]).min(axis=1)
    assert np.all(np.abs(steady_force(rate, u, p) - demand) <= best + 1e-9)


@pytest.fixture(scope="module")
def semi_env():
    return gym.make(ID, actuator="semi-active", backend="linear", duration=1.0)


def _observation(env, **channels: float) -> np.ndarray:
    """The normalised observation of the physical channel values ``channels`` (others 0)."""
    base = env.unwrapped
    x = np.zeros(len(base.obs_names))
    for name, value in channels.items():
        x[base.obs_names.index(name)] = value
    return (x / base.obs_scale).astype(np.float32)


def test_onoff_skyhook_switches_on_where_the_damper_can_give_the_skyhook_force(semi_env):
    ctrl = OnOffSkyhook(semi_env)
    cases = [  # (carbody velocity ẋ2, deflection rate v = ẋ1 − ẋ2) m/s → command
        (0.1, -0.05, 1.0),  # body rising, bogie falling away: the damper pulls the body down
        (0.1, 0.05, 0.0),  # body rising, bogie rising faster: the damper would push it up
        (-0.1, 0.05, 1.0),
        (-0.1, -0.05, 0.0),
        (0.0, 0.05, 0.0),  # no skyhook force
        (0.1, 0.0, 0.0),  # the damper gives no force
    ]
    for v2, rate, want in cases:
        obs = _observation(semi_env, carbody_vel=v2, deflection_rate=rate)
        (u,) = ctrl.predict(obs)[0]
        assert u == want, (v2, rate)
    # the continuous skyhook: the same demand through the inverse
    sky = DamperSkyhook(semi_env)
    assert sky.c_sky == default_c_sky(semi_env.unwrapped.vehicle_params)
    obs = _observation(semi_env, carbody_vel=0.05, deflection_rate=-0.1)
    want = damper_command(-sky.c_sky * 0.05, -0.1, DAMPER)
    assert sky.predict(obs)[0][0] == pytest.approx(want, abs=1e-6) and 0 < want < 1


def test_a_shared_name_builds_the_controller_of_the_envs_actuator_and_others_are_refused(
    semi_env,
):
    force_env = gym.make(ID, backend="linear", duration=1.0)
    build, kwargs, _ = CONTROLLERS["skyhook"]
    assert type(build(force_env, **kwargs)) is Skyhook
    assert type(build(semi_env, **kwargs)) is DamperSkyhook
    with pytest.raises(ValueError, match="commands actuator='semi-active', the env has "):
        ClippedLQG(force_env)
    with pytest.raises(ValueError, match="LQG commands actuator='force', the env has actuator"):
        LQG(semi_env)
    with pytest.raises(ValueError, match="observation must be 'sensors' for clipped-lqg"):
        ClippedLQG(gym.make(ID, actuator="semi-active", observation="full", backend="linear"))


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["lqg", "--actuator", "semi-active"], "--actuator semi-active: lqg is a controller of"),
        (["clipped-lqg"], "--actuator force: clipped-lqg is a controller of --actuator semi"),
        (["passive", "--actuator", "force", "--env", "crash"], "--actuator: only for --env"),
        (
            ["modal-skyhook", "--actuator", "semi-active", "--env", "vehicle"],
            "--actuator semi-active: modal-skyhook is a controller of the force actuator",
        ),
    ],
)
def test_cli_refuses_a_controller_of_the_other_actuator_naming_the_flag(argv, words, capsys):
    assert main(["evaluate", *argv]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


def _episode(env, ctrl, seed: int) -> tuple[np.ndarray, dict]:
    obs, _ = env.reset(seed=seed)
    commands = []
    while True:
        action, _ = ctrl.predict(obs)
        commands.append(action[0])
        obs, _, term, trunc, info = env.step(action)
        assert not term
        if trunc:
            return np.array(commands), info


@pytest.mark.parametrize("name", list(SEMI_ACTIVE_CONTROLLERS))
def test_every_semi_active_baseline_runs_an_episode_with_commands_in_0_1(name):
    cls, kwargs, env_kwargs = CONTROLLERS[name]
    env = gym.make(
        ID, actuator="semi-active", backend="reference", track_class=4, duration=3.0, **env_kwargs
    )
    commands, info = _episode(env, cls(env, **kwargs), 1000)
    assert np.all((commands >= 0.0) & (commands <= 1.0))
    # the damper followed the commands (its filtered command is observed and in info)
    assert 0.0 <= info["damper_command"] <= 1.0 and np.isfinite(info["damper_force"])
    if name in ("passive", "constant-max"):
        assert np.all(commands == (name == "constant-max"))
    elif name != "groundhook":  # the switching laws use the whole range
        assert commands.min() == 0.0 and commands.max() == 1.0


def test_clipped_lqg_and_skyhook_ride_better_than_the_softest_damper_on_class_4():
    """On the reference vehicle (class 4 at its maximum speed, the held-out track of seed 1000)
    the Wk-weighted carbody acceleration of both controllers is below that of command 0."""
    kwargs = {"backend": "reference", "track_class": 4, "actuator": "semi-active"}
    a_w = {}
    for name in ("passive", "clipped-lqg", "skyhook"):
        factory, env_kwargs, _ = load_policy(name)
        a_w[name] = run_policy(factory, {**kwargs, **env_kwargs}, 1, 1000)["a_w"]
    assert a_w["clipped-lqg"] < 0.97 * a_w["passive"]
    assert a_w["skyhook"] < 0.97 * a_w["passive"]


def test_cli_evaluate_semi_active_baselines_with_their_contacts(capsys):
    argv = ["evaluate", "clipped-lqg", "skyhook-onoff", "skyhook", "groundhook", "passive"]
    opts = ["--actuator", "semi-active", "--backend", "linear", "--track-class", "4"]
    assert main([*argv, *opts, "--episodes", "1"]) == 0
    out = capsys.readouterr().out
    assert "actuator: semi-active (passive: damper command 0)" in out
    head, *rows = out.splitlines()[1:]
    assert head.split()[:2] == ["class", "policy"] and "contacts" in head.split()
    policies = [ln.split()[1] for ln in rows]
    assert policies == ["passive", "skyhook", "clipped-lqg", "skyhook-onoff", "groundhook"]
    at = head.index("contacts")
    assert all(ln[at : at + 8].strip().isdigit() for ln in rows)


ROW = {"rms_acc": 0.3, "a_w_reduction_%": 0.0, "wz": 2.0, "max_defl_mm": 30.0}


def test_the_tables_say_where_a_lower_a_w_comes_with_more_contacts():
    rows = [
        {**ROW, "track_class": 4, "policy": "lqg", "a_w": 0.40, "contacts": 76},
        {**ROW, "track_class": 4, "policy": "passive", "a_w": 0.55, "contacts": 95},
        {**ROW, "track_class": 4, "policy": "ppo_vertical", "a_w": 0.38, "contacts": 92},
        {**ROW, "track_class": 6, "policy": "lqg", "a_w": 0.10, "contacts": 0},
        {**ROW, "track_class": 6, "policy": "ppo_vertical", "a_w": 0.08, "contacts": 0},
    ]
    lines = format_rows(rows).splitlines()
    assert lines[0].split()[-1] == "note"
    assert lines[3].endswith("more contacts than lqg")  # not than passive: fewer than it
    assert all(not ln.endswith("contacts than lqg") for i, ln in enumerate(lines) if i != 3)
    # the whole vehicle: the mean a_w over the floor points
    three = {k: np.full(3, 0.1) for k in ("rms_acc", "a_w_reduction_%", "a_ZP95_Wb", "Wz")}
    vehicle = [
        {**three, "track_class": 5, "speed_kmh": 144.0, "ood": 0, **r}
        for r in (
            {"policy": "lqg", "a_w": np.array([0.3, 0.2, 0.3]), "contacts": 4},
            {"policy": "ppo", "a_w": np.array([0.35, 0.1, 0.3]), "contacts": 9},
        )
    ]
    assert format_vehicle_rows(vehicle).splitlines()[2].endswith("more contacts than lqg")
    assert "note" not in format_vehicle_rows(vehicle[:1])
    # the benchmark's table: the agent's means over its seeds beside each baseline's value
    bench = [
        {"policy": p, "seed": s, "case": "class 4", "metric": m, "value": v, "unit": u}
        for p, s, m, v, u in (
            ("ppo", 0, "a_w", 0.37, "m/s²"),
            ("ppo", 1, "a_w", 0.39, "m/s²"),
            ("ppo", 0, "contacts", 92.0, "substeps"),
            ("ppo", 1, "contacts", 53.0, "substeps"),
            ("lqg", "", "a_w", 0.40, "m/s²"),
            ("lqg", "", "contacts", 76.0, "substeps"),
            ("passive", "", "a_w", 0.55, "m/s²"),
            ("passive", "", "contacts", 60.0, "substeps"),
        )
    ]
    table = summary_table(bench, "ppo")
    assert "| class 4 | contacts (substeps) | 72.5 ± 28 " in table
    assert "- class 4: ppo has a lower a_w with more contacts than passive (bump-stop" in table
    bench[3]["value"] = 20.0  # mean 56 contacts: fewer than both
    assert "more contacts" not in summary_table(bench, "ppo")
    # the transfer gap: on the reference side
    gap = [
        {"case": "class 4", "policy": p, "metric": "a_w (m/s²)", "surrogate": s, "reference": r}
        | {"gap": s / r - 1, "contacts_surrogate": cs, "contacts_reference": cr}
        for p, s, r, cs, cr in (("lqg", 0.41, 0.40, 70, 76), ("ppo", 0.36, 0.38, 60, 92))
    ]
    text = format_gap(gap)
    assert text.splitlines()[0].split()[-1] == "contacts"
    assert text.splitlines()[2].endswith("  60 / 92")
    assert "class 4, ppo: more contacts than lqg (reference)" in text


def test_semi_active_configs_get_the_semi_active_baselines():
    assert baselines_of(ID, {"actuator": "semi-active"}) == SEMI_ACTIVE_BASELINES
    assert baselines_of(ID, {"actuator": "force"}) == ("passive", "skyhook", "lqg", "lqr")
    assert baselines_of(ID, {}) == ("passive", "skyhook", "lqg", "lqr")
    assert set(SEMI_ACTIVE_BASELINES) <= set(SEMI_ACTIVE_CONTROLLERS)


def test_the_benchmark_runs_the_semi_active_baselines_with_the_configs_actuator():
    rows = held_out(ID, list(SEMI_ACTIVE_BASELINES), 1, None, None, {"actuator": "semi-active"})
    assert {r["policy"] for r in rows} == set(SEMI_ACTIVE_BASELINES)
    assert {r["case"] for r in rows} == {"class 4", "class 5", "class 6"}
    metrics = {(r["policy"], r["case"], r["metric"]): r["value"] for r in rows}
    for policy in SEMI_ACTIVE_BASELINES:
        assert metrics[(policy, "class 4", "contacts")] >= 0.0
    # the damper at command 0 rides worse than the LQG's demand clipped to it
    assert metrics[("clipped-lqg", "class 5", "a_w")] < metrics[("passive", "class 5", "a_w")]
    table = summary_table(rows, "ppo")
    assert "| class 4 | contacts (substeps) | – |" in table
