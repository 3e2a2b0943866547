"""EN 12299 vertical comfort: the Wb weighting and a_ZP95."""

import numpy as np
import pytest

from railgym.comfort import WeightingFilter, a_zp95, wb_weighting, weighted_rms

#: ISO 8041 reference value of Wb at its reference frequency 100 rad/s (15.915 Hz)
WB_REFERENCE = (100.0 / (2.0 * np.pi), 0.8126)
#: Wb design-goal weighting factors of ISO 8041-1:2017 Annex B, Table B.1 (the weighting of
#: ISO 2631-4:2001 Annex A and EN 12299, band limiting included) at the one-third-octave
#: band centres 10^(n/10) Hz, n = -10 ... 26 (0.1 to 398 Hz), 4 significant figures; as
#: transcribed in the phonometry project (github.com/jmrplens/phonometry,
#: tests/reference_data/vibration.py, ``ISO8041_1_ANNEX_B_FACTORS["Wb"]``)
WB_TABLE_B1 = (
    0.02494,
    0.03941,
    0.06198,
    0.09645,
    0.1464,
    0.2113,
    0.28,
    0.3347,
    0.3666,
    0.3808,
    0.3853,
    0.3864,
    0.3916,
    0.4168,
    0.496,
    0.6653,
    0.885,
    1.026,
    1.054,
    1.026,
    0.9745,
    0.9042,
    0.8144,
    0.7088,
    0.5973,
    0.4906,
    0.395,
    0.3118,
    0.2389,
    0.1734,
    0.1154,
    0.06929,
    0.03818,
    0.01999,
    0.0102,
    0.005154,
    0.002591,
)


def iso_wb(f):
    """ISO 2631-4 Annex A in the standard's notation (p = j 2πf), gain K = 1.024."""
    p = 2j * np.pi * np.asarray(f, float)
    w1, w2, w4, w5, w6 = (2 * np.pi * x for x in (0.4, 100.0, 16.0, 2.5, 4.0))
    h_h = 1 / (1 + np.sqrt(2) * w1 / p + (w1 / p) ** 2)
    h_l = 1 / (1 + np.sqrt(2) * p / w2 + (p / w2) ** 2)
    h_t = (1 + p / w4) / (1 + p / (0.55 * w4) + (p / w4) ** 2)
    h_s = (1 + p / (0.9 * w5) + (p / w5) ** 2) / (1 + p / (0.95 * w6) + (p / w6) ** 2)
    return np.abs(1.024 * h_h * h_l * h_t * h_s * (w5 / w6) ** 2)


def test_wb_gain_matches_the_tabulated_reference_value_and_the_formula():
    f_ref, g_ref = WB_REFERENCE
    assert wb_weighting(f_ref) == pytest.approx(g_ref, rel=0.02)
    assert wb_weighting(f_ref) == pytest.approx(g_ref, abs=1e-4)  # in fact to 4 digits
    f = np.geomspace(0.1, 200.0, 50)
    np.testing.assert_allclose(wb_weighting(f), iso_wb(f), rtol=1e-12)
    # shape: attenuates below the 2.5–4 Hz step (≈ (2.5/4)² · K at low frequency)
    assert wb_weighting(1.0) < 0.45 < 0.95 < wb_weighting(6.0)


def test_wb_gain_matches_the_standard_table_at_every_third_octave_band():
    f = 10.0 ** (np.arange(-10, 27) / 10.0)
    assert len(WB_TABLE_B1) == f.size
    np.testing.assert_allclose(wb_weighting(f), WB_TABLE_B1, rtol=0.02)
    # the table is printed to 4 significant figures: the formula agrees to that rounding
    np.testing.assert_allclose(wb_weighting(f), WB_TABLE_B1, rtol=1e-3)


def test_digital_wb_filter_follows_the_analog_gain_at_the_env_rate():
    f = np.array([0.5, 1.0, 2.0, 4.0, 8.0, 10.0])
    flt = WeightingFilter(100.0, "Wb", lowpass=False)
    np.testing.assert_allclose(flt.gain(f), wb_weighting(f, lowpass=False), rtol=0.02)
    t = np.arange(6000) / 100.0
    a = 0.3 * np.sin(2 * np.pi * 4.0 * t)
    got = weighted_rms(a, 100.0, "Wb", discard=10.0, lowpass=False)
    assert got == pytest.approx(0.3 / np.sqrt(2) * wb_weighting(4.0), rel=0.02)


def test_a_zp95_is_the_percentile_of_the_five_second_rms_values():
    fs, f0 = 200.0, 5.0  # 25 whole cycles per window: the phase runs on across windows
    amps = 0.05 * np.arange(1, 21)
    t = np.arange(int(5.0 * fs)) / fs
    a = np.concatenate([amp * np.sin(2 * np.pi * f0 * t) for amp in amps])
    expect = np.percentile(amps / np.sqrt(2) * wb_weighting(f0, lowpass=False), 95.0)
    assert a_zp95(a, fs, lowpass=False) == pytest.approx(expect, rel=0.02)
    with pytest.raises(ValueError, match="window"):
        a_zp95(a[:100], fs, lowpass=False)
