"""The benchmarks' shared timing (``benchmarks._timing``): spread, target parsing and the
met / missed / unresolved verdict on synthetic samples, and the windows and interleaved rounds
on a fake clock. Nothing here times real work."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from benchmarks import _timing, measured
from benchmarks.__main__ import format_row
from benchmarks._timing import interleaved, parse_target, spread, verdict, verdict_of


def test_spread_is_the_interquartile_range_relative_to_the_median():
    assert spread([1.0, 2.0, 3.0, 4.0, 5.0]) == pytest.approx(2.0 / 3.0)
    assert spread([5.0, 1.0, 4.0, 2.0, 3.0]) == pytest.approx(2.0 / 3.0)  # order-free
    assert spread([2.5] * 5) == 0.0
    assert np.isnan(spread([7.0])) and np.isnan(spread([1.0, 2.0]))  # too few for a spread
    # one outlier window (a descheduled thread) leaves the IQR of five samples alone
    assert spread([1.0, 1.0, 1.0, 1.0, 50.0]) == 0.0


@pytest.mark.parametrize(
    ("target", "parsed"),
    [
        ("≤ 1.3", ("≤", 1.3)),
        ("≥ 25", ("≥", 25.0)),
        ("≥ 1/3", ("≥", 1 / 3)),
        ("<= 2 s", ("≤", 2.0)),
        (">= 0.85", ("≥", 0.85)),
        ("> 1", (">", 1.0)),
        ("≤ 1.10", ("≤", 1.1)),
        ("", None),
        ("-", None),
        ("2x serial", None),
        (">= greedy", None),
        ("<= 3 x idle", None),
        ("vectorised", None),
        ("≥ 1/0", None),
    ],
)
def test_parse_target(target, parsed):
    got = parse_target(target)
    if parsed is None:
        assert got is None
    else:
        assert got is not None and got[0] == parsed[0] and got[1] == pytest.approx(parsed[1])


@pytest.mark.parametrize(
    ("samples", "target", "want"),
    [
        # 1.2 against ≤ 1.3: margin 8.3 %, IQR 1.7 %: met
        ([1.18, 1.19, 1.2, 1.21, 1.22], "≤ 1.3", "met"),
        # 1.25 against ≤ 1.3: margin 4 %, IQR 8 %: unresolved
        ([1.1, 1.2, 1.25, 1.3, 1.4], "≤ 1.3", "unresolved"),
        # 1.4 against ≤ 1.3: missed by 7.1 %, IQR 1.4 %
        ([1.38, 1.39, 1.4, 1.41, 1.42], "≤ 1.3", "missed"),
        # a share of 24 % against ≥ 25: missed by 4.2 %, IQR 0.8 %; resolved at 5 %
        ([23.8, 23.9, 24.0, 24.1, 24.2], "≥ 25", "missed"),
        # the same share with an IQR of 8 %: unresolved
        ([22.0, 23.0, 24.0, 24.9, 26.0], "≥ 25", "unresolved"),
        ([0.4, 0.41, 0.42, 0.43, 0.44], "≥ 1/3", "met"),
        ([6.0, 6.1, 6.2], "≥ 5", "met"),
        # no numeric target: no verdict
        ([1.0, 2.0, 3.0], "2x serial", ""),
        ([1.0, 2.0, 3.0], "", ""),
    ],
)
def test_verdict_of_samples_against_a_target(samples, target, want):
    assert verdict_of(samples, target) == want


def test_verdict_needs_a_spread_and_a_finite_value():
    assert verdict(1.0, None, "≤ 2") == ""  # not timed in repeated windows
    assert verdict_of([1.0, 1.0], "≤ 2") == ""  # too few windows for a spread
    assert measured("x", [1.0], "s", "≤ 2")["spread"] is None
    assert verdict(float("nan"), 0.0, "≤ 2") == ""
    assert verdict(2.0, 0.0, "≤ 2") == "met" and verdict(2.0, 0.0, "< 2") == "missed"


@given(
    st.floats(0.01, 100.0),
    st.floats(0.0, 0.5),
    st.sampled_from(["≤", "≥"]),
    st.floats(0.01, 100.0),
)
def test_verdict_is_unresolved_exactly_when_the_spread_exceeds_the_margin(v, s, op, bound):
    got = verdict(v, s, f"{op} {bound!r}")
    margin = abs(v - bound) / v
    if s > margin:
        assert got == "unresolved"
    else:
        assert got == ("met" if (v <= bound if op == "≤" else v >= bound) else "missed")


def test_windows_and_interleaved_rounds_on_a_fake_clock(monkeypatch):
    """A call of ``a`` takes 10 ms, one of ``b`` 30 ms on a clock that moves only in them:
    each window is at least the window length, the rounds alternate, the samples are exact."""
    clock, order = [0.0], []
    monkeypatch.setattr(_timing, "time", SimpleNamespace(perf_counter=lambda: clock[0]))

    def call(name: str, cost: float):
        def fn() -> None:
            clock[0] += cost
            order.append(name)

        return fn

    w = interleaved({"a": call("a", 0.01), "b": call("b", 0.03)}, repeats=5, window_s=0.2)
    assert w["a"].calls * 0.01 >= 0.2 and w["b"].calls * 0.03 >= 0.2
    np.testing.assert_allclose(w["a"].seconds, 0.01, rtol=1e-9)
    np.testing.assert_allclose(w["b"].seconds, 0.03, rtol=1e-9)
    assert w["a"].seconds.shape == w["b"].seconds.shape == (5,)
    timed = order[-5 * (w["a"].calls + w["b"].calls) :]  # the 5 rounds, after calibration
    per_round = ["a"] * w["a"].calls + ["b"] * w["b"].calls
    assert timed == per_round * 5
    ratio = w["b"].seconds / w["a"].seconds
    assert verdict_of(ratio, "≤ 3.5") == "met" and verdict_of(ratio, "≥ 3.5") == "missed"


def test_printed_row_has_the_spread_and_the_verdict():
    line = format_row(measured("x ratio", [1.18, 1.19, 1.2, 1.21, 1.22], "×", "≤ 1.3", "ctx"))
    assert line.split()[:5] == ["x", "ratio", "1.2", "×", "1.7"]
    assert "% ≤ 1.3" in line and " met " in line and line.endswith("ctx")
    line = format_row({"name": "y", "value": 3.0, "unit": "s", "target": "<= 2 s"})
    assert " — " in line and "met" not in line and "missed" not in line  # no spread, no verdict


def test_surrogate_ratios_are_per_round_ratios_with_spread_and_verdict():
    """``benchmarks.bench_replaced.ratio_rows`` on synthetic env-steps/s, one sample per
    round: the ratio rows are the medians of the per-round ratios (not the ratio of the
    medians), with their spread, and met / missed / unresolved against ≥ 5 and ≥ 100."""
    from benchmarks.bench_replaced import TARGET_FMU, TARGET_REFERENCE, ratio_rows

    rates = {
        "surrogate": np.array([8.0e6, 2.0e6, 3.0e6, 6.6e6, 6.2e6]),
        "reference": np.array([1.0e6, 1.0e6, 0.5e6, 1.1e6, 1.0e6]),
        "fmu": np.array([5e4, 5e4, 5e4, 5e4, 5e4]),
    }
    rows = {r["name"]: r for r in ratio_rows("Env", rates, "16 FMU instances", threads=2)}
    ref = rows["  surrogate / reference (Env)"]
    per_round = [8.0, 2.0, 6.0, 6.0, 6.2]  # median 6; the medians' ratio 6.2e6 / 1e6 = 6.2
    assert ref["value"] == pytest.approx(6.0) and ref["target"] == TARGET_REFERENCE == "≥ 5"
    assert ref["spread"] == pytest.approx(0.2 / 6.0) == spread(per_round)  # IQR 6 → 6.2
    assert " met " in format_row(ref)  # margin 1/6 above the IQR
    fmu = rows["  surrogate / FMU env (Env)"]
    assert fmu["value"] == pytest.approx(124.0) and fmu["target"] == TARGET_FMU == "≥ 100"
    assert fmu["spread"] == pytest.approx(spread(rates["surrogate"] / 5e4))
    # 124 with an IQR of 58 % (60 → 132 per round): the spread exceeds the 19 % margin
    assert " unresolved " in format_row(fmu)
    assert rows["Env surrogate vector (1024)"]["value"] == pytest.approx(6.2)  # M steps/s
    assert rows["Env FMU in the loop (16)"]["value"] == pytest.approx(50.0)  # k steps/s
    assert "2 numba threads" in rows["Env reference vector (1024)"]["context"]
    slow = {"surrogate": np.full(5, 4e6), "reference": np.full(5, 1e6)}
    rows = {r["name"]: r for r in ratio_rows("Env", slow, "FMPy is not installed")}
    assert " missed " in format_row(rows["  surrogate / reference (Env)"])  # 4 < 5, no spread
    skipped = rows["  surrogate / FMU env (Env)"]
    assert np.isnan(skipped["value"]) and skipped["spread"] is None
    assert skipped["context"] == "FMPy is not installed" and "Env FMU in the loop (16)" not in rows


def test_fmu_env_is_skipped_with_the_reason(monkeypatch):
    """No FMU env (and nothing built) for the crash env, whose reference exports no FMU, nor
    where FMPy or a C compiler is missing: the row says why."""
    from benchmarks import bench_replaced

    env, why = bench_replaced.fmu_env("railgym/TrainCrash-v1", Path("unused"))
    assert env is None and why == "no FMU of its reference (exported: vertical, vehicle)"
    reason = "no C compiler to build the FMU (install gcc or set CC)"
    monkeypatch.setattr(bench_replaced, "fmu_unavailable", lambda: reason)
    for env_id in ("railgym/VerticalSuspension-v1", "railgym/VerticalVehicle-v1"):
        assert bench_replaced.fmu_env(env_id, Path("unused")) == (None, reason)
