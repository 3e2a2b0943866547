"""``railgym evaluate --gap``: the transfer gap of policies between surrogate and reference."""

from __future__ import annotations

import math

import pytest

from agents.commands.cli import main
from agents.evaluation.gap import format_gap, gap_crash, gap_vehicle, gap_vertical, relative_gap
from agents.evaluation.runs import run_policy
from agents.policies.loading import load_policy


def test_relative_gap():
    assert relative_gap(1.1, 1.0) == pytest.approx(0.1)
    assert relative_gap(-0.9, -1.0) == pytest.approx(0.1)
    assert relative_gap(0.0, 0.0) == 0.0 and relative_gap(2.5, 2.5) == 0.0
    assert relative_gap(1e-3, 0.0) == math.inf and relative_gap(-1e-3, 0.0) == -math.inf


def test_vertical_gap_is_the_relative_difference_of_the_two_backends_on_the_same_tracks():
    """Each row pairs the same policy and class on both backends: the gap equals the relative
    difference of two independent run_policy calls; the reference against itself gives 0."""
    rows = gap_vertical(["skyhook", "passive"], [6], episodes=2, backends=("surrogate", "linear"))
    assert [(r["case"], r["policy"]) for r in rows] == [
        ("class 6", "skyhook"),
        ("class 6", "passive"),
    ]
    factory, kwargs, _ = load_policy("skyhook")
    direct = [
        run_policy(factory, {**kwargs, "backend": b, "track_class": 6}, 2, 1000)["a_w"]
        for b in ("surrogate", "linear")
    ]
    sky = rows[0]
    assert (sky["surrogate"], sky["reference"]) == (direct[0], direct[1])
    assert sky["gap"] == pytest.approx((direct[0] - direct[1]) / direct[1], rel=1e-12)
    assert sky["gap"] != 0.0  # the linear suspension is not the surrogate element
    same = gap_vertical(["skyhook"], [6], episodes=2, backends=("linear", "linear"))
    assert same[0]["gap"] == 0.0 and same[0]["reference"] == direct[1]


def test_vehicle_gap_per_floor_point_of_the_reference_against_itself_is_zero():
    rows = gap_vehicle(
        ["passive"], [5], [100.0], episodes=1, duration=2.0, backends=("reference", "reference")
    )
    assert [r["metric"] for r in rows] == [
        "a_w front (m/s²)",
        "a_w centre (m/s²)",
        "a_w rear (m/s²)",
    ]
    assert all(r["case"] == "class 5, 100 km/h" and r["reference"] > 0 for r in rows)
    assert all(r["gap"] == 0.0 for r in rows)


def test_crash_gap_names_every_car_and_zone_and_is_zero_against_itself():
    rows = gap_crash(
        ["passive"], speeds_kmh=[30.0], payloads_t=[(0.0, 0.0)], backends=("reference",) * 2
    )
    metrics = [r["metric"] for r in rows]
    for i in (1, 2):
        assert f"peak decel car {i} (g)" in metrics and f"10 ms mean decel car {i} (g)" in metrics
        assert f"max crush zone {i} (m)" in metrics and f"intrusion zone {i} (m)" in metrics
    assert all(r["gap"] == 0.0 and r["case"] == "30 km/h, payload 0/0 t" for r in rows)
    peak = {r["metric"]: r["reference"] for r in rows}
    assert peak["peak decel car 1 (g)"] >= peak["10 ms mean decel car 1 (g)"] > 1.0
    text = format_gap(rows)
    assert "largest |gap| of passive: 0.00 %" in text


def test_crash_gap_rows_say_which_side_the_env_cut_as_diverged():
    """At 400 km/h both backends end the run as diverged (a zone crushed through a car): each
    row says so in its ``diverged`` column and a line under the table names the runs; at
    30 km/h no row is marked."""
    rows = gap_crash(["passive"], speeds_kmh=[400.0, 30.0], payloads_t=[(0.0, 0.0)])
    fast = [r for r in rows if r["case"].startswith("400 ")]
    slow = [r for r in rows if r["case"].startswith("30 ")]
    assert fast and all(r["diverged"] == "surrogate and reference" for r in fast)
    assert slow and all(r["diverged"] == "" for r in slow)
    head, *lines = format_gap(rows).splitlines()
    assert head.endswith("  diverged")
    assert all(ln.endswith("surrogate and reference") for ln in lines if ln.startswith("400 "))
    assert all(ln.endswith("  no") for ln in lines if ln.startswith("30 "))
    (note,) = [ln for ln in lines if ln.startswith("diverged:")]
    assert note.startswith(
        "diverged: passive, 400 km/h, payload 0/0 t (surrogate and reference): the env cut"
    )


def test_cli_gap_prints_both_values_and_a_zero_gap_against_the_same_backend(capsys):
    argv = ["evaluate", "skyhook", "--gap", "--track-class", "4", "--episodes", "1"]
    assert main([*argv, "--backend", "surrogate"]) == 0
    out = capsys.readouterr().out
    (line,) = [ln for ln in out.splitlines() if ln.startswith("class 4")]
    _, _, policy, metric, unit, s, r, gap, c_s, _, c_r = line.split()  # contacts: s / r
    assert (policy, metric, unit) == ("skyhook", "a_w", "(m/s²)")
    assert s == r and float(gap) == 0.0 and float(s) > 0 and c_s == c_r
    pair = "surrogate (the packaged element) vs surrogate (the packaged element)"
    assert f"{pair} on vehicle the packaged one" in out
    assert main([*argv, "--backend", "linear"]) == 0
    out = capsys.readouterr().out
    (line,) = [ln for ln in out.splitlines() if ln.startswith("class 4")]
    s, r, gap = (float(x) for x in line.split()[5:8])
    assert gap == pytest.approx(100 * (s - r) / r, abs=0.01 + 1e-3 * abs(gap)) and gap != 0.0


VEHICLE_V3 = "railgym/VerticalVehicle-v3"


@pytest.mark.parametrize(
    ("extra", "flag"),
    [
        (["--envelope", "--env", "crash"], "--envelope"),
        (["--env", "crash", "--workers", "2"], "--workers"),
        (["--env", "crash", "--backend", "linear"], "--backend"),
        (["--speed-kmh", "90"], "--speed-kmh"),
        # the FMU draws its tracks whole: a streaming version would compare other tracks
        (["--backend", "fmu", "--fmu-map", "m.yaml", "--env-version", "3"], "--env-version 3"),
        (["--env", "vehicle", "--backend", "fmu", "--env-id", VEHICLE_V3], "--env-id"),
    ],
)
def test_cli_gap_bad_flag_combinations_are_one_error_naming_the_flag(extra, flag, capsys):
    assert main(["evaluate", "passive", "--gap", *extra]) == 2
    err = capsys.readouterr().err
    assert flag in err and "Traceback" not in err


def test_crash_gap_of_a_trained_policy_against_itself_is_zero():
    """A stable-baselines3 policy acts by its mean action: sampled exploration noise (torch's
    global generator, not the env's seed) made the reference differ from itself by 14–27 %."""
    pytest.importorskip("stable_baselines3")
    rows = gap_crash(
        ["ppo-crash"], speeds_kmh=[50.0], payloads_t=[(0.0, 0.0)], backends=("reference",) * 2
    )
    assert len(rows) == 8 and all(r["gap"] == 0.0 for r in rows)
    peak = {r["metric"]: r["reference"] for r in rows}
    assert 7.0 < peak["peak decel car 1 (g)"] < 10.0
