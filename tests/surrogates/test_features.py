"""Feature extraction (paper section 3.1): time histories, vertical and crash training data."""

from __future__ import annotations

import numpy as np
import pytest

from surrogates.features import (
    CRASH_KEYS,
    LOADING,
    UNLOADING,
    TimeHistory,
    crash_features,
    crash_features_from,
    split_branches,
    vertical_features,
    vertical_features_from,
)


def runs(labels: np.ndarray) -> np.ndarray:
    """Lengths of the runs of equal labels."""
    bounds = np.concatenate([[0], np.flatnonzero(np.diff(labels)) + 1, [labels.size]])
    return np.diff(bounds)


def loop() -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-linear crush: up 0 → 1 m, hold, down to 0.4 m, up to 1.5 m, down to 1.2 m.

    Returns the deformation and its labels: sample i carries the sign of the step i-1 → i,
    a hold keeps the previous label, sample 0 takes sample 1's.
    """
    pieces = [
        (np.linspace(0.0, 1.0, 21), LOADING),
        (np.full(6, 1.0), LOADING),  # plateau after loading: still loading
        (np.linspace(1.0, 0.4, 16)[1:], UNLOADING),
        (np.linspace(0.4, 1.5, 23)[1:], LOADING),
        (np.linspace(1.5, 1.2, 7)[1:], UNLOADING),
    ]
    d = np.concatenate([p for p, _ in pieces])
    labels = np.concatenate([np.full(p.size, lab) for p, lab in pieces])
    return d, labels


def test_split_finds_the_known_branches_exactly() -> None:
    d, expected = loop()
    np.testing.assert_array_equal(split_branches(d), expected)
    # irregular sampling: the rates change from step to step, their signs do not
    t = np.cumsum(np.random.default_rng(0).uniform(0.5e-3, 1.5e-3, d.size))
    np.testing.assert_array_equal(split_branches(d, t), expected)
    # a plateau first takes the label of the first move
    np.testing.assert_array_equal(split_branches(np.r_[np.zeros(4), d]), np.r_[[1] * 4, expected])
    np.testing.assert_array_equal(split_branches(np.r_[2.0, 2.0, 2.0, 1.0, 0.0]), [-1] * 5)
    np.testing.assert_array_equal(split_branches(np.full(7, 0.3)), [LOADING] * 7)


def test_split_is_robust_to_noise() -> None:
    d, expected = loop()
    noisy = d + np.random.default_rng(1).normal(0.0, 0.002, d.size)  # steps are 0.05 m
    raw = split_branches(noisy, min_length=1, tol=0.0)
    assert runs(raw).size > runs(expected).size  # without the guards the plateau flickers
    labels = split_branches(noisy, min_length=3)
    assert runs(labels).min() >= 3
    slopes = np.ones(d.size, dtype=bool)
    slopes[20:27] = False  # the plateau (samples 21-26) and the sample before it
    np.testing.assert_array_equal(labels[slopes], expected[slopes])


def test_split_on_a_noisy_oscillating_crush() -> None:
    t = np.linspace(0.0, 2.0, 2001)
    clean = 0.3 * t + 0.05 * np.sin(2 * np.pi * 3.0 * t)  # reverses 12 times
    truth = np.where(np.gradient(clean, t) > 0, LOADING, UNLOADING)
    noisy = clean + np.random.default_rng(2).normal(0.0, 1e-4, t.size)  # steps up to 1.2e-3
    labels = split_branches(noisy, t, min_length=5)
    assert runs(labels).min() >= 5
    assert runs(labels).size == runs(truth).size
    # the only mismatches lie within a few samples of a reversal (hysteresis, noise)
    turns = np.flatnonzero(np.diff(truth)) + 1
    wrong = np.flatnonzero(labels != truth)
    assert np.abs(wrong[:, None] - turns[None, :]).min(axis=1).max() <= 6
    assert wrong.size < 0.03 * t.size


def test_vertical_features_recover_a_linear_suspension() -> None:
    t = np.linspace(0.0, 20.0, 1001)  # 20 s at 50 Hz, as in the paper
    k2, c2, m2 = 4.0e5, 3.0e4, 3.2e4  # N/m, N·s/m, kg
    x1 = 0.01 * np.sin(2 * np.pi * 1.3 * t) + 0.004 * np.sin(2 * np.pi * 4.1 * t)
    x2 = 0.008 * np.sin(2 * np.pi * 0.9 * t + 0.4)
    v1 = 0.01 * 2 * np.pi * 1.3 * np.cos(2 * np.pi * 1.3 * t) + 0.004 * 2 * np.pi * 4.1 * np.cos(
        2 * np.pi * 4.1 * t
    )
    v2 = 0.008 * 2 * np.pi * 0.9 * np.cos(2 * np.pi * 0.9 * t + 0.4)
    a2 = (k2 * (x1 - x2) + c2 * (v1 - v2)) / m2  # eq. (1), second row
    th = TimeHistory(t, {"x1": x1, "x2": x2, "v1": v1, "v2": v2, "a2": a2})
    U, V = vertical_features_from(th, m2)
    assert U.shape == (1001, 2) and V.shape == (1001,)
    coef, *_ = np.linalg.lstsq(U, V, rcond=None)
    np.testing.assert_allclose(coef, [k2, c2], rtol=1e-10)
    U2, V2 = vertical_features(x1, x2, v1, v2, a2, m2)
    np.testing.assert_array_equal(U2, U)
    np.testing.assert_array_equal(V2, V)


def test_vertical_features_errors() -> None:
    x = np.zeros(10)
    with pytest.raises(ValueError, match="m2 must be a positive"):
        vertical_features(x, x, x, x, x, 0.0)
    with pytest.raises(ValueError, match="m2 must be a positive"):
        vertical_features(x, x, x, x, x, np.nan)
    with pytest.raises(ValueError, match="v2 has 9 samples, expected 10"):
        vertical_features(x, x, x, x[:9], x, 1.0)
    th = TimeHistory(np.arange(10.0), {"x1": x, "x2": x, "v1": x, "v2": x})
    with pytest.raises(ValueError, match="no channel 'a2'"):
        vertical_features_from(th, 1.0)


def crash_record() -> tuple[np.ndarray, ...]:
    """A wall element with stiff elastic unloading and an interface with its own cycles."""
    d, labels = loop()
    n = d.size
    t = np.linspace(0.0, 0.2, n)
    k_load, k_unload = 2.0e6, 8.0e6  # N/m
    peak = np.maximum.accumulate(d)
    f1 = np.where(labels == LOADING, k_load * d, k_load * peak - k_unload * (peak - d))
    crush2 = np.interp(np.arange(n), [0, 30, 45, n - 1], [0.0, 0.3, 0.1, 0.35])
    f2 = 5.0e6 * crush2
    return t, d, d - crush2, f1, f2, labels, crush2


def test_crash_features_split_each_element_by_its_own_deformation() -> None:
    t, x1, x2, f1, f2, labels, crush2 = crash_record()
    out = crash_features(t, x1, x2, f1, f2)
    assert tuple(out) == CRASH_KEYS
    U, V = out["wall_loading"]
    assert U.shape == ((labels == LOADING).sum(), 1) and V.shape == (U.shape[0],)
    np.testing.assert_allclose(V, 2.0e6 * U[:, 0], rtol=1e-12)
    U, V = out["wall_unloading"]
    assert U.shape[0] == (labels == UNLOADING).sum()
    assert np.all(V < 2.0e6 * U[:, 0])  # unloading runs below the loading line
    U, V = out["interface_loading"]
    Uu, _ = out["interface_unloading"]
    np.testing.assert_allclose(V, 5.0e6 * U[:, 0], rtol=1e-12)
    np.testing.assert_allclose(U[:, 0], np.r_[crush2[:31], crush2[46:]], atol=1e-15)
    np.testing.assert_allclose(Uu[:, 0], crush2[31:46], atol=1e-15)
    th = TimeHistory(t, {"lead": x1, "second": x2, "F_wall": f1, "F_if": f2})
    out2 = crash_features_from(th, x1="lead", x2="second", f1="F_wall", f2="F_if")
    for key in CRASH_KEYS:
        np.testing.assert_array_equal(out2[key][0], out[key][0])
        np.testing.assert_array_equal(out2[key][1], out[key][1])


def test_split_and_crash_errors() -> None:
    with pytest.raises(ValueError, match="deformation has a non-finite value at index 2"):
        split_branches([0.0, 1.0, np.inf, 2.0])
    with pytest.raises(ValueError, match="min_length must be >= 1"):
        split_branches([0.0, 1.0, 2.0], min_length=0)
    with pytest.raises(ValueError, match="tol must be"):
        split_branches([0.0, 1.0, 2.0], tol=-1.0)
    with pytest.raises(ValueError, match="t has 2 samples, expected 3"):
        split_branches([0.0, 1.0, 2.0], t=[0.0, 1.0])
    t = np.arange(5.0)
    with pytest.raises(ValueError, match="f2 has 4 samples, expected 5"):
        crash_features(t, t, t, t, t[:4])


def test_time_history_container() -> None:
    t = np.linspace(0.0, 20.0, 1001)
    th = TimeHistory(t, {"x1": np.sin(t), "F": np.cos(t)}, units={"x1": "m", "F": "N"})
    assert th.sample_rate == pytest.approx(50.0, rel=1e-12)
    assert len(th) == 1001 and th.names == ("x1", "F") and list(th) == ["x1", "F"]
    np.testing.assert_array_equal(th["F"], np.cos(t))
    assert th["t"] is th.t and "x1" in th and "x2" not in th
    assert th.units == {"t": "s", "x1": "m", "F": "N"}
    with pytest.raises(ValueError, match="read-only"):
        th["x1"][0] = 1.0
    with pytest.raises(KeyError, match="no channel 'x2'"):
        th["x2"]


@pytest.mark.parametrize(
    ("t", "channels", "units", "match"),
    [
        ([0.0, 1.0, 2.0], {"x1": [1.0, 2.0]}, None, "channel 'x1' has 2 samples, expected 3"),
        ([0.0, 1.0, 1.0], {"x1": [1.0, 2.0, 3.0]}, None, r"t\[2\] = 1.0 <= t\[1\] = 1.0"),
        (
            [0.0, 1.0, 2.0],
            {"a": [1.0, 2.0, 3.0], "b": [1.0, np.nan, 3.0]},
            None,
            "channel 'b' has a non-finite value at index 1",
        ),
        ([0.0, 1.0, 2.0], {"x1": [[1.0, 2.0, 3.0]]}, None, "channel 'x1' must be a 1-D array"),
        ([0.0, np.inf], {"x1": [1.0, 2.0]}, None, "t has a non-finite value at index 1"),
        ([0.0], {"x1": [1.0]}, None, "t needs at least 2 samples"),
        ([0.0, 1.0], {}, None, "channels is empty"),
        ([0.0, 1.0], {"t": [1.0, 2.0]}, None, "reserved"),
        ([0.0, 1.0], {"x1": [1.0, 2.0]}, {"x2": "m"}, "units names 'x2'"),
    ],
)
def test_time_history_errors(t: list, channels: dict, units: dict | None, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        TimeHistory(t, channels, units)
