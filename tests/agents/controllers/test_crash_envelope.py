"""TrainCrash-v1 over an impact envelope: seeded draws, reset options, payload physics, the
crash criteria and the energy check in ``info``, reward terms."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest
import yaml

from agents.controllers.crash_baselines import CrashPassive, rollout
from railgym.envs.crash.env import TrainCrashEnv, TrainCrashVectorEnv
from railgym.vehicles.crash.criteria import crash_pulse, moving_average_peak
from railgym.vehicles.crash.scenario import CrushZone, load_scenario, parse_scenario

KMH = 1 / 3.6


def _run(env, action=(0.0, 0.0), **reset):
    obs, info = env.reset(**reset)
    while True:
        obs, r, term, trunc, info = env.step(np.asarray(action, np.float32))
        if term or trunc:
            return info


def test_envelope_draws_are_seeded_and_within_the_ranges():
    env = TrainCrashEnv(backend="surrogate", scenario="envelope", max_duration=0.01)
    draws = {}
    for seed in range(8):
        _, info = env.reset(seed=seed)
        _, again = env.reset(seed=seed)
        assert info["initial_speed"] == again["initial_speed"]
        np.testing.assert_array_equal(info["payload_kg"], again["payload_kg"])
        draws[seed] = (info["initial_speed"], *info["payload_kg"])
    v, lead, passenger = np.array(list(draws.values())).T
    assert np.all((25 * KMH <= v) & (v <= 50 * KMH)) and np.ptp(v) > 5 * KMH
    assert np.all((0 <= lead) & (lead <= 2e3)) and np.all((0 <= passenger) & (passenger <= 8e3))
    assert len(set(v)) == 8 and len(set(passenger)) == 8
    # the payload is in the masses: the car_masses accessor
    sc = load_scenario("envelope")
    np.testing.assert_allclose(env.car_masses, sc.car_masses + [lead[-1], passenger[-1]])
    # the velocity observation is scaled by the envelope's top speed
    assert env.obs_scale[2] == pytest.approx(50 * KMH)


@pytest.mark.parametrize("backend", ["surrogate", "reference"])
def test_vector_envelope_sub_envs_equal_single_envs(next_step_autoreset, backend):
    kw = {"backend": backend, "scenario": "envelope", "max_duration": 0.2}
    venv = TrainCrashVectorEnv(num_envs=3, **kw)
    singles = [TrainCrashEnv(**kw) for _ in range(3)]
    obs_v, info_v = venv.reset(seed=11)
    for i, e in enumerate(singles):
        o, info = e.reset(seed=11 + i)
        np.testing.assert_array_equal(obs_v[i], o)
        np.testing.assert_array_equal(info_v["payload_kg"][i], info["payload_kg"])
        assert info_v["initial_speed"][i] == info["initial_speed"]
    rng = np.random.default_rng(0)
    steps = next_step_autoreset(singles)
    for _ in range(260):  # across the autoresets at truncation: new draws from each generator
        act = rng.uniform(-1, 1, (3, 2)).astype(np.float32)
        obs_v, rew_v, term_v, trunc_v, info_v = venv.step(act)
        for i, (o, r, te, tr, info, _) in enumerate(steps.step(act)):
            np.testing.assert_array_equal(obs_v[i], o)
            assert rew_v[i] == r and term_v[i] == te and trunc_v[i] == tr
            assert info_v["initial_speed"][i] == info["initial_speed"]


def test_options_fix_each_quantity_and_the_draws_are_made_all_the_same():
    kw = {"backend": "surrogate", "scenario": "envelope", "max_duration": 0.01}
    free, fixed = TrainCrashEnv(**kw), TrainCrashEnv(**kw)
    _, drawn = free.reset(seed=4)
    _, info = fixed.reset(seed=4, options={"speed_kmh": 32.0})
    assert info["initial_speed"] == 32.0 / 3.6
    np.testing.assert_array_equal(info["payload_kg"], drawn["payload_kg"])  # still drawn
    _, info = fixed.reset(seed=4, options={"payload_t": [1.5, 6.0]})
    assert info["initial_speed"] == 32.0 / 3.6  # the fixed speed is kept
    np.testing.assert_array_equal(info["payload_kg"], [1500.0, 6000.0])
    _, info = fixed.reset(seed=4, options={"payload_t": {"lead": 0.5}, "speed_kmh": None})
    assert info["initial_speed"] == drawn["initial_speed"]  # None: drawn again
    np.testing.assert_array_equal(info["payload_kg"], [500.0, 0.0])
    _, info = fixed.reset(seed=4, options={"payload_t": 2.0})
    np.testing.assert_array_equal(info["payload_kg"], [2000.0, 2000.0])
    # the next episode without a seed follows the generator as if nothing were fixed
    fixed.reset(seed=4, options={"payload_t": None})
    np.testing.assert_array_equal(fixed.reset()[1]["payload_kg"], free.reset()[1]["payload_kg"])
    # the paper scenario has no envelope, but a fixed speed and payload
    paper = TrainCrashEnv(backend="reference", max_duration=0.01)
    _, info = paper.reset(seed=0, options={"speed_kmh": 25.0, "payload_t": [0.0, 4.0]})
    assert info["initial_speed"] == 25.0 / 3.6 and info["payload_kg"][1] == 4000.0
    # vector env: options apply to the sub-envs it resets
    venv = TrainCrashVectorEnv(num_envs=2, **kw)
    _, info = venv.reset(seed=0, options={"speed_kmh": 45.0})
    np.testing.assert_array_equal(info["initial_speed"], [45.0 / 3.6] * 2)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"speed": 10.0}, r"options\['speed'\] is not a reset option"),
        ({"speed_kmh": "fast"}, r"options\['speed_kmh'\] must be a number"),
        ({"speed_kmh": 1e9}, r"options\['speed_kmh'\] must be in \[1, 500\]"),
        ({"speed_kmh": float("nan")}, r"options\['speed_kmh'\] must be finite"),
        ({"speed_kmh": True}, r"options\['speed_kmh'\] must be a number"),
        ({"payload_t": -1.0}, r"options\['payload_t'\] must be in \[0, 1000\]"),
        ({"payload_t": [1.0, 2.0, 3.0]}, r"options\['payload_t'\] must have 2 items"),
        ({"payload_t": [1.0, np.inf]}, r"options\['payload_t'\]\[1\] must be finite"),
        ({"payload_t": {"cab": 1.0}}, r"options\['payload_t'\]\['cab'\] is not a car type"),
    ],
)
def test_bad_options_name_the_option(options, message):
    env = TrainCrashEnv(backend="surrogate", scenario="envelope", max_duration=0.01)
    with pytest.raises(ValueError, match=message):
        env.reset(seed=0, options=options)


@pytest.mark.parametrize(
    "envelope, message",
    [
        ({"speed_kmh": [50, 25]}, r"crash\.envelope\.speed_kmh must be \[low, high\] with low"),
        ({"speed_kmh": [25, 900]}, r"crash\.envelope\.speed_kmh\[1\] must be in \[1, 500\]"),
        ({"speed_kmh": [0.5, 20]}, r"crash\.envelope\.speed_kmh\[0\] must be in \[1, 500\]"),
        ({"speed_kmh": [10, 20, 30]}, r"crash\.envelope\.speed_kmh must be a number or"),
        ({"speed_kmh": "fast"}, r"crash\.envelope\.speed_kmh must be a number"),
        ({"payload_t": {"lead": [-1, 2]}}, r"crash\.envelope\.payload_t\.lead\[0\] must be"),
        ({"payload_t": {"lead": [3, 2]}}, r"crash\.envelope\.payload_t\.lead must be \[low"),
        ({"payload_t": {"cab": 1}}, r"crash\.envelope\.payload_t\.cab is not a known field"),
        ({"speed": [25, 50]}, r"crash\.envelope\.speed is not a known field"),
    ],
)
def test_bad_envelope_ranges_name_the_field(crash_raw, envelope, message):
    raw = crash_raw()
    raw["envelope"] = envelope
    with pytest.raises(ValueError, match=message):
        parse_scenario(raw)


def test_an_envelope_speed_alone_is_fixed_and_the_speed_argument_fixes_it(crash_raw):
    raw = crash_raw()
    raw["envelope"] = {"speed_kmh": 30}
    sc = parse_scenario(raw)
    assert sc.envelope.speed == (30 / 3.6, 30 / 3.6) and sc.envelope.payload_lead == (0.0, 0.0)
    env = TrainCrashEnv(backend="surrogate", scenario="envelope", speed=12.0, max_duration=0.01)
    assert {env.reset(seed=s)[1]["initial_speed"] for s in range(3)} == {12.0}


def test_payload_enters_the_reference_energy_balance():
    """With 8 t on the passenger car the energy balance still closes and the zones and
    friction take up the larger kinetic energy ½ Σ (m + payload) v²."""
    env = TrainCrashEnv(backend="reference")
    info = _run(env, seed=0, options={"payload_t": [0.0, 8.0]})
    e0 = 0.5 * float(np.sum(env.car_masses)) * info["initial_speed"] ** 2
    assert env.car_masses[1] == pytest.approx(load_scenario("paper").car_masses[1] + 8e3)
    assert abs(info["energy_error"]) < 1e-6
    absorbed = info["absorbed_energy_J"].sum() + info["friction_work_J"]
    assert absorbed == pytest.approx(e0, rel=0.01)
    heavier = info["max_crush_m"].sum()
    light = _run(env, seed=0, options={"payload_t": None})["max_crush_m"].sum()
    assert heavier > light * 1.05  # more energy, more crush


@pytest.mark.parametrize("backend", ["reference", "surrogate"])
def test_info_criteria_equal_the_criteria_of_the_recorded_histories(backend):
    venv = TrainCrashVectorEnv(num_envs=1, backend=backend, scenario="envelope")
    r = rollout(venv, CrashPassive(venv), seed=2)[0]
    info = _run(TrainCrashEnv(backend=backend, scenario="envelope"), seed=2)
    pulse = crash_pulse(r.t, r.v, r.a, g=r.gravity)
    np.testing.assert_allclose(info["pulse_mean_decel_g"], pulse.mean_g, rtol=1e-12)
    ma = moving_average_peak(r.t, r.v, 0.01, g=r.gravity)
    np.testing.assert_allclose(info["moving_average_peak_g"], ma, rtol=1e-9)
    crit = r.criteria()
    np.testing.assert_allclose(info["intrusion_m"], crit.intrusion_m, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(info["mean_decel_passed"], crit.passed["mean_decel"])
    assert info["criteria_passed"] == crit.all_passed
    # the old whole-episode mean stays, lower than the pulse mean
    assert np.all(info["mean_decel_g"] < info["pulse_mean_decel_g"])


def test_env_pulse_mean_of_a_constant_force_crash_is_analytic():
    """One rigid car into a plateau absorber: the pulse mean is F / (m g), t_stop = m v0 / F."""
    force, v0, mass = 1.0e6, 10.0, 30.0e3
    sc = load_scenario("paper")
    wall = CrushZone("wall", (1e-3, 5.0), (force, force), 1.0, 1e9, 0.0, 0.15)
    lead = replace(sc.lead, mass=mass, n_nodes=2, axial_rigidity=1e12, damping_ratio=0.0)
    sc = replace(sc, n_cars=1, friction=0.0, speed=v0, lead=lead, wall=wall)
    env = TrainCrashEnv(backend="reference", scenario=sc, n_cars=None, control_dt=1e-4)
    info = _run(env, action=(0.0,))
    assert info["pulse_mean_decel_g"][0] == pytest.approx(force / (mass * sc.gravity), rel=2e-3)
    assert info["moving_average_peak_g"][0] == pytest.approx(force / (mass * sc.gravity), rel=2e-3)
    # stopping distance m v0² / (2 F) = 1.5 m, 0.5 m beyond the 1 m absorber: fails
    assert info["max_crush_m"][0] == pytest.approx(mass * v0**2 / (2 * force), rel=2e-3)
    assert info["intrusion_m"][0] == pytest.approx(0.5, rel=5e-3)
    assert info["mean_decel_passed"][0] and not info["criteria_passed"]


def test_scenario_criteria_limits_decide_pass_and_fail(crash_raw, tmp_path):
    raw = crash_raw()
    raw["criteria"] = {"mean_decel_g": 3.0, "intrusion_mm": 10.0, "peak_decel_g": 7.5}
    path = tmp_path / "strict.yaml"
    path.write_text(yaml.safe_dump({"crash": raw}), encoding="utf-8")
    sc = load_scenario(str(path))
    assert sc.criteria.intrusion_m == pytest.approx(0.01) and sc.criteria.mean_decel_g == 3.0
    info = _run(TrainCrashEnv(backend="reference", scenario=str(path)))
    # paper case, passive: pulse means 3.54 / 2.80 g, peaks 7.99 / 3.50 g
    np.testing.assert_array_equal(info["mean_decel_passed"], [False, True])
    np.testing.assert_array_equal(info["peak_decel_passed"], [False, True])
    assert info["intrusion_passed"].all() and not info["criteria_passed"]
    raw["criteria"] = {"mean_decel_g": -1.0}
    with pytest.raises(ValueError, match=r"crash\.criteria\.mean_decel_g must be non-negative"):
        parse_scenario(raw)


def test_reward_terms_sum_to_the_reward_in_both_envs():
    env = TrainCrashEnv(backend="reference", speed=50 * KMH)  # intrudes: both terms non-zero
    env.reset(seed=0)
    seen = set()
    while True:
        _, r, term, trunc, info = env.step(np.full(2, -1.0, np.float32))
        terms = info["reward_terms"]
        assert set(terms) == {"decel", "intrusion", "peak", "divergence"}
        assert sum(terms.values()) == pytest.approx(r, rel=1e-12, abs=1e-15)
        seen |= {k for k, v in terms.items() if v != 0.0}
        if term or trunc:
            break
    assert seen == {"decel", "intrusion"} and info["crash_over"]
    venv = TrainCrashVectorEnv(num_envs=2, backend="surrogate")
    venv.reset(seed=0)
    _, r, *_, infos = venv.step(np.zeros((2, 2), np.float32))
    total = sum(infos["reward_terms"][k] for k in ("decel", "intrusion", "peak", "divergence"))
    np.testing.assert_allclose(total, r, rtol=1e-12)
    assert infos["reward_terms"]["_decel"].all() and infos["_crash_over"].all()


def test_surrogate_energy_check_flags_the_paper_variant_not_the_hysteretic():
    """``energy_error`` on the surrogate: work a zone returned beyond the elastic energy it
    could store at its work peak, over the initial energy (docs/envs/crash.md)."""
    errors = {}
    for variant in ("paper", "hysteretic"):
        env = TrainCrashEnv(backend="surrogate", surrogate_variant=variant)
        info = _run(env, seed=0)
        errors[variant] = info["energy_error"]
    assert errors["paper"] > 0.01  # creates energy at rebound
    assert 0.0 <= errors["hysteretic"] < 1e-3


def test_raise_extrapolation_is_rejected_by_the_crash_models():
    from railgym.envs.crash.env import default_surrogate

    sur = copy.deepcopy(default_surrogate(load_scenario("paper")))
    sur.elements["wall"].loading.extrapolation = "raise"
    with pytest.raises(ValueError, match=r"extrapolation='raise'.*use 'clip' or 'linear'"):
        TrainCrashEnv(surrogate=sur)


def test_envelope_evaluation_fixes_speed_and_payload_and_summarises():
    from agents.controllers.crash_baselines import CrashPassive as Passive
    from agents.controllers.crash_baselines import SpeedAdaptive
    from agents.evaluation.crash_report import envelope_rows, envelope_summary, envelope_table

    policies = {"passive": Passive, "speed-adaptive": SpeedAdaptive}
    rows = envelope_rows(policies, {"control_dt": 0.005}, (25.0,), ((0.0, 0.0), (2.0, 8.0)))
    assert [(r["payload_t"], r["controller"]) for r in rows] == [
        ((0.0, 0.0), "passive"),
        ((0.0, 0.0), "speed-adaptive"),
        ((2.0, 8.0), "passive"),
        ((2.0, 8.0), "speed-adaptive"),
    ]
    env = TrainCrashEnv(backend="reference", scenario="envelope", control_dt=0.005)
    info = _run(env, seed=0, options={"speed_kmh": 25.0, "payload_t": [2.0, 8.0]})
    np.testing.assert_array_equal(rows[2]["criteria"].peak_decel_g, info["peak_decel_g"])
    s = envelope_summary(rows)
    assert s["passive"]["excess_over_passive_m"] == 0.0
    # issue 11: the speed-adaptive rule beats passive at 25 km/h without intrusion
    assert s["speed-adaptive"]["peak_g"] < 0.9 * s["passive"]["peak_g"]
    assert s["speed-adaptive"]["intrusion_m"] == 0.0
    assert "| speed-adaptive |" in envelope_table(rows)


def test_peak_term_pays_the_worst_car_peak_once():
    """The ``peak`` term charges each growth of the worst car's peak deceleration: over an
    episode it sums to −w · max_k peak_k / 1 g; with weight 0 the reward is unchanged."""
    weighted = TrainCrashEnv(backend="reference", reward_weights={"peak": 2.0})
    plain = TrainCrashEnv(backend="reference")
    for env in (weighted, plain):
        env.reset(seed=0)
    total = 0.0
    while True:
        *_, r, term, trunc, info = weighted.step(np.zeros(2, np.float32))
        _, r0, *_ = plain.step(np.zeros(2, np.float32))
        total += info["reward_terms"]["peak"]
        assert r == pytest.approx(r0 + info["reward_terms"]["peak"], rel=1e-12, abs=1e-12)
        if term or trunc:
            break
    assert total == pytest.approx(-2.0 * info["peak_decel_g"].max(), rel=1e-12)


def test_shipped_config_return_is_the_targets_objective():
    """``configs/agents/ppo_crash.yaml``'s reward sums over a crash to −0.2 per g of the worst
    car's peak and −0.002 per mm of intrusion (summed over the zones), nothing else: checked at
    50 km/h, where the passive train intrudes."""
    from agents.training.train_config import load_config

    kwargs = {**load_config("ppo_crash").env_kwargs, "backend": "reference"}
    env = TrainCrashEnv(**kwargs)
    env.reset(seed=0, options={"speed_kmh": 50.0, "payload_t": 0.0})
    total = 0.0
    while True:
        _, r, term, trunc, info = env.step(np.zeros(2, np.float32))
        total += r
        if term or trunc:
            break
    intrusion_mm = 1e3 * np.sum(info["intrusion_m"])
    assert intrusion_mm > 100.0
    expected = -0.2 * info["peak_decel_g"].max() - 0.002 * intrusion_mm
    assert total == pytest.approx(expected, rel=1e-9)
