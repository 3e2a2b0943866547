"""Tests for railgym.comfort: ISO 2631-1 weighting, Sperling index, running comfort."""

import numpy as np
import pytest
from scipy import signal

from railgym.comfort import (
    RunningComfort,
    WeightingFilter,
    sperling_b,
    sperling_label,
    sperling_wz,
    weighted_rms,
    wk_gain,
    wk_weighting_tf,
)

FS = 1000.0

# ISO 2631-1:1997 Table 3 weighting factors (x 1000) at one-third-octave centre frequencies.
TABLE3_WK = {1.0: 482, 2.0: 531, 4.0: 967, 5.0: 1039, 8.0: 1036, 16.0: 768, 31.5: 405}
TABLE3_WD = {0.5: 853, 1.0: 1011, 2.0: 890, 4.0: 512, 8.0: 253, 16.0: 125}


def iso_formula(f, kind):
    """Annex A in the standard's own notation, p = j 2 pi f."""
    p = 2j * np.pi * np.asarray(f, float)
    w1, w2 = 2 * np.pi * 0.4, 2 * np.pi * 100.0
    h_h = 1 / (1 + np.sqrt(2) * w1 / p + (w1 / p) ** 2)
    h_l = 1 / (1 + np.sqrt(2) * p / w2 + (p / w2) ** 2)
    if kind == "Wk":
        w3 = w4 = 2 * np.pi * 12.5
        w5, w6 = 2 * np.pi * 2.37, 2 * np.pi * 3.35
        h_s = (1 + p / (0.91 * w5) + (p / w5) ** 2) / (1 + p / (0.91 * w6) + (p / w6) ** 2)
        h_s *= (w5 / w6) ** 2
    else:
        w3 = w4 = 2 * np.pi * 2.0
        h_s = 1.0
    h_t = (1 + p / w3) / (1 + p / (0.63 * w4) + (p / w4) ** 2)
    return np.abs(h_h * h_l * h_t * h_s)


def sine(f, amplitude, duration, fs=FS):
    t = np.arange(int(round(duration * fs))) / fs
    return amplitude * np.sin(2 * np.pi * f * t)


@pytest.mark.parametrize("kind", ["Wk", "Wd"])
def test_analog_gain_matches_standard_formula_and_table(kind):
    f = np.geomspace(0.1, 400.0, 60)
    np.testing.assert_allclose(wk_gain(f, kind), iso_formula(f, kind), rtol=1e-12)
    b, a = wk_weighting_tf(kind)
    _, h = signal.freqs(b, a, worN=2 * np.pi * f)
    np.testing.assert_allclose(np.abs(h), iso_formula(f, kind), rtol=1e-9)
    assert (len(b) - 1, len(a) - 1) == ((5, 8) if kind == "Wk" else (3, 6))
    table = TABLE3_WK if kind == "Wk" else TABLE3_WD
    for fi, g in table.items():  # table: 3 significant digits at nominal frequencies
        assert wk_gain(fi, kind) * 1000 == pytest.approx(g, abs=1.0)


@pytest.mark.parametrize("f", [0.5, 1.0, 2.0, 4.0, 5.0, 8.0, 16.0, 31.5, 63.0])
@pytest.mark.parametrize("kind", ["Wk", "Wd"])
def test_sine_through_discrete_filter_has_analog_gain(f, kind):
    # 10 s settling (high-pass time constant ~0.56 s), then an integer number of periods
    n_per = int(np.ceil(10.0 * f))
    a = sine(f, 1.0, 10.0 + n_per / f)
    y = WeightingFilter(FS, kind).filter(a)[int(10.0 * FS) :]
    gain = np.sqrt(2.0 * np.mean(y**2))
    assert gain == pytest.approx(float(wk_gain(f, kind)), rel=2e-3)
    # same measurement through weighted_rms of a 1 m/s² amplitude sine
    a_w = weighted_rms(a, FS, kind, discard=10.0)
    assert a_w == pytest.approx(float(wk_gain(f, kind)) / np.sqrt(2.0), rel=2e-3)


def test_low_rate_filter_accuracy_and_lowpass_policy():
    with pytest.warns(UserWarning, match="low-pass is omitted"):
        flt = WeightingFilter(100.0, "Wk")
    assert not flt.lowpass
    f = np.array([0.5, 1.0, 2.0, 4.0, 8.0, 10.0])
    ref_k = wk_gain(f, "Wk", lowpass=False)
    np.testing.assert_allclose(flt.gain(f), ref_k, rtol=5e-3)
    ref_d = wk_gain(f, "Wd", lowpass=False)
    flt_d = WeightingFilter(100.0, "Wd", lowpass=False)
    np.testing.assert_allclose(flt_d.gain(f), ref_d, rtol=1.5e-2)
    with pytest.raises(ValueError, match="lowpass"):
        WeightingFilter(100.0, "Wk", lowpass=True)
    assert WeightingFilter(FS, "Wk").lowpass
    # at 1 kHz the whole band 0.5-80 Hz follows the analog weighting within 0.2 %
    f = np.geomspace(0.5, 80.0, 40)
    for kind in ("Wk", "Wd"):
        np.testing.assert_allclose(WeightingFilter(FS, kind).gain(f), wk_gain(f, kind), rtol=2e-3)


def test_streaming_equals_whole_signal():
    rng = np.random.default_rng(3)
    a = rng.normal(size=5000)
    flt = WeightingFilter(FS, "Wk")
    whole = flt.filter(a)
    cuts = np.sort(rng.choice(np.arange(1, a.size), size=40, replace=False))
    for _ in range(2):  # second pass checks reset
        flt.reset()
        parts = [flt.step(c) for c in np.split(a, cuts)]
        np.testing.assert_allclose(np.concatenate(parts), whole, rtol=0, atol=1e-12)
    flt.reset()
    singles = np.array([flt.step(x)[0] for x in a[:300]])
    np.testing.assert_allclose(singles, whole[:300], rtol=0, atol=1e-12)


def test_sperling_b_hand_value():
    # f = 1 Hz: 0.737 sqrt(1.9735 / (0.723² + 1.5262²)) = 0.737 sqrt(1.9735 / 2.852015)
    assert float(sperling_b(1.0, "horizontal")) == pytest.approx(0.613070, rel=1e-5)
    assert float(sperling_b(1.0, "vertical")) == pytest.approx(0.613070 / 1.25, rel=1e-5)


@pytest.mark.parametrize("f", [1.0, 2.0, 5.0, 12.0])
@pytest.mark.parametrize("direction", ["vertical", "horizontal"])
def test_sperling_of_pure_sine_matches_closed_form(f, direction):
    amp = 0.3  # m/s² = 30 cm/s²
    wz = sperling_wz(sine(f, amp, 60.0), FS, direction)
    expected_integral = float(sperling_b(f, direction)) ** 2 * (100 * amp) ** 2 / 2
    assert wz**6.67 == pytest.approx(expected_integral, rel=2e-2)
    assert wz == pytest.approx(expected_integral ** (1 / 6.67), rel=3e-3)


def test_sperling_ignores_content_outside_band():
    wz_in = sperling_wz(sine(5.0, 0.3, 60.0), FS)
    wz_both = sperling_wz(sine(5.0, 0.3, 60.0) + sine(80.0, 1.0, 60.0), FS)
    assert wz_both == pytest.approx(wz_in, rel=1e-3)


def test_sperling_label():
    assert sperling_label(0.5) == "not noticeable"
    assert sperling_label(1.0) == "just noticeable"
    assert sperling_label(2.7) == "more pronounced but not unpleasant"
    assert sperling_label(3.3) == "very irregular"
    assert sperling_label(4.6) == "extremely unpleasant"


def test_zero_input_gives_zero():
    z = np.zeros(4000)
    assert weighted_rms(z, FS) == 0.0
    assert sperling_wz(z, FS) == 0.0
    rc = RunningComfort(FS)
    assert rc.update(z) == (0.0, 0.0)
    s = rc.summary()
    assert s["a_w"] == s["mtvv"] == s["peak"] == s["vdv"] == s["crest_factor"] == 0.0
    assert s["duration"] == pytest.approx(4.0)


def test_running_comfort_stationary_sine():
    f, amp, tau = 1.0, 2.0, 1.0
    a = sine(f, amp, 40.0)
    rc = RunningComfort(FS, "Wk", tau=tau, discard=10.0)
    for chunk in np.array_split(a, 400):
        a_w, mtvv = rc.update(chunk)
    g = float(wk_gain(f)) * amp
    assert a_w == pytest.approx(weighted_rms(a, FS, discard=10.0), rel=1e-12)
    assert a_w == pytest.approx(g / np.sqrt(2), rel=2e-3)
    # exponential running mean square of g² sin²: (g²/2)(1 + ripple), ripple = 1/|1 + j 2 w tau|
    ripple = 1 / np.hypot(1.0, 2 * 2 * np.pi * f * tau)
    assert mtvv == pytest.approx(g / np.sqrt(2) * np.sqrt(1 + ripple), rel=2e-3)
    s = rc.summary()
    assert s["peak"] == pytest.approx(g, rel=2e-3)
    assert s["crest_factor"] == pytest.approx(np.sqrt(2), rel=3e-3)
    assert s["vdv"] == pytest.approx((3 / 8 * g**4 * 30.0) ** 0.25, rel=3e-3)
    assert s["duration"] == pytest.approx(30.0)
    rc.reset()
    assert rc.update(a) == pytest.approx((a_w, mtvv), rel=1e-12)


def test_running_comfort_burst_mtvv():
    # 3 s burst of a 5 Hz sine in 60 s: a_w = g/sqrt(2 * 20), MTVV ~ sqrt(1 - e^-3) g/sqrt(2)
    # (approximate: filter transients at the burst edges, running-r.m.s. ripple ~0.8 %)
    a = np.zeros(int(60 * FS))
    a[int(20 * FS) : int(23 * FS)] = sine(5.0, 1.0, 3.0)
    rc = RunningComfort(FS, "Wk", tau=1.0)
    for chunk in np.array_split(a, 600):
        a_w, mtvv = rc.update(chunk)
    g = float(wk_gain(5.0))
    assert a_w == pytest.approx(g / np.sqrt(40), rel=1.5e-2)
    assert mtvv == pytest.approx(g / np.sqrt(2) * np.sqrt(1 - np.exp(-3)), rel=2e-2)
    assert mtvv / a_w > 1.5


def test_bad_arguments_raise():
    a = np.ones(100)
    with pytest.raises(ValueError, match="fs"):
        WeightingFilter(10.0)
    with pytest.raises(ValueError, match="fs"):
        weighted_rms(a, float("nan"))
    with pytest.raises(ValueError, match="kind"):
        WeightingFilter(FS, "Wz")
    with pytest.raises(ValueError, match="kind"):
        wk_gain(1.0, "wk")
    with pytest.raises(ValueError, match="discard"):
        weighted_rms(a, FS, discard=1.0)
    with pytest.raises(ValueError, match="a must"):
        weighted_rms(np.ones((10, 2)), FS)
    with pytest.raises(ValueError, match="fs"):
        sperling_wz(a, 50.0)
    with pytest.raises(ValueError, match="direction"):
        sperling_wz(a, FS, direction="lateral")
    with pytest.raises(ValueError, match="nperseg"):
        sperling_wz(a, FS, nperseg=1000)
    with pytest.raises(ValueError, match="tau"):
        RunningComfort(FS, tau=0.0)
    with pytest.raises(ValueError, match="wz"):
        sperling_label(-1.0)
