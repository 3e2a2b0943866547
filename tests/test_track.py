"""Tests for railgym.track: FRA spectra, random profiles and time inputs."""

import ast
import math
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, signal

from railgym import track

# Published FRA values (cm²·rad/m, rad/m, km/h), Garg & Dukkipati 1984 / paper table 7.
PUBLISHED = {
    3: (0.6816, 0.4128, 0.8520, 0.8245, 96.0),
    4: (0.5376, 0.3027, 1.1312, 0.8245, 128.0),
    5: (0.2095, 0.0762, 0.8209, 0.8245, 144.0),
    6: (0.0339, 0.0339, 0.4380, 0.8245, 176.0),
}
BAND = (1.0, 100.0)
OMEGA_LO, OMEGA_HI = 2 * math.pi / BAND[1], 2 * math.pi / BAND[0]


def band_integral(track_class, kind="vertical", lo=OMEGA_LO, hi=OMEGA_HI, weight=None):
    """∫ G(Ω)·weight(Ω) dΩ over [lo, hi] by adaptive quadrature, m²."""

    def f(w):
        g = track.fra_psd(w, track_class, kind)
        return g if weight is None else g * weight(w)

    return integrate.quad(f, lo, hi, limit=400)[0]


@pytest.mark.parametrize("cls", sorted(PUBLISHED))
def test_class_parameters_are_published_values_in_si(cls):
    a_v, a_a, om_s, om_c, kmh = PUBLISHED[cls]
    p = track.class_parameters(cls)
    assert p.track_class == cls and p.k == 0.25 and p.verified
    assert p.a_v == pytest.approx(a_v * 1e-4, rel=1e-12)
    assert p.a_a == pytest.approx(a_a * 1e-4, rel=1e-12)
    assert (p.omega_s, p.omega_c) == (om_s, om_c)
    assert track.class_speed(cls) == pytest.approx(kmh / 3.6, rel=1e-12)


def test_secondary_source_classes_are_flagged():
    table = track.load_fra_table()
    assert sorted(table) == [1, 2, 3, 4, 5, 6]
    assert not table[1].verified and not table[2].verified
    # Rougher classes have larger roughness constants.
    a_v = [table[c].a_v for c in range(1, 7)]
    assert all(a > b for a, b in zip(a_v, a_v[1:], strict=False))


@pytest.mark.parametrize("kind", track.KINDS)
def test_psd_formula(kind):
    a_v, a_a, om_s, om_c, _ = PUBLISHED[5]
    w = np.array([0.05, 0.3, 1.0, 4.0])
    if kind == "crosslevel":
        expected = 4 * 0.25 * a_v * om_c**2 / ((w**2 + om_c**2) * (w**2 + om_s**2))
    else:
        a = a_v if kind == "vertical" else a_a
        expected = 0.25 * a * om_c**2 / (w**2 * (w**2 + om_c**2))
    np.testing.assert_allclose(track.fra_psd(w, 5, kind), expected * 1e-4, rtol=1e-12)
    assert isinstance(track.fra_psd(1.0, 5, kind), float)


@pytest.mark.parametrize("kind", track.KINDS)
def test_psd_monotonic_decreasing(kind):
    w = np.logspace(-3, 2, 500)
    for cls in range(1, 7):
        assert np.all(np.diff(track.fra_psd(w, cls, kind)) < 0.0)


@pytest.mark.parametrize(
    ("cls", "kind", "seed"),
    [(3, "vertical", 1), (6, "vertical", 2), (5, "alignment", 3), (4, "crosslevel", 4)],
)
def test_welch_psd_matches_in_octave_bands_and_variance(cls, kind, seed):
    dx = 0.05
    _, z = track.fra_profile(cls, 50_000.0, dx, seed, BAND, kind=kind)
    f, p_f = signal.welch(z, fs=1.0 / dx, nperseg=2**16)
    omega, g = 2 * np.pi * f, p_f / (2 * np.pi)  # per cycle/m -> per rad/m
    edges = OMEGA_LO * 2.0 ** np.arange(7)
    assert edges[-1] <= OMEGA_HI
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        sel = (omega >= lo) & (omega < hi)
        expected = band_integral(cls, kind, lo, hi) / (hi - lo)
        assert g[sel].mean() == pytest.approx(expected, rel=0.15), (lo, hi)
    assert np.var(z) == pytest.approx(band_integral(cls, kind), rel=0.02)


def test_profile_grid_seed_and_scaling():
    x, z = track.fra_profile(3, 100.0, 0.05, 42)
    assert x.shape == z.shape == (2001,) and x.dtype == z.dtype == np.float64
    np.testing.assert_array_equal(x, np.arange(2001) * 0.05)
    np.testing.assert_array_equal(z, track.fra_profile(3, 100.0, 0.05, 42)[1])
    np.testing.assert_array_equal(
        z, track.fra_profile(3, 100.0, 0.05, np.random.default_rng(42))[1]
    )
    assert not np.allclose(z, track.fra_profile(3, 100.0, 0.05, 43)[1])
    # Same phases, same spectral shape: class 6 is class 3 scaled by sqrt(A_v6 / A_v3).
    z6 = track.fra_profile(6, 100.0, 0.05, 42)[1]
    ratio = track.class_parameters(6).a_v / track.class_parameters(3).a_v
    np.testing.assert_allclose(z6, z * math.sqrt(ratio), rtol=1e-12, atol=1e-18)


def test_class6_smoother_than_class3():
    var3 = np.var(track.fra_profile(3, 5_000.0, 0.05, 5)[1])
    var6 = np.var(track.fra_profile(6, 5_000.0, 0.05, 6)[1])
    assert var6 < 0.2 * var3
    assert band_integral(6) < band_integral(3)


def test_profile_slope_is_derivative():
    x, z, s = track.fra_profile_with_slope(4, 300.0, 0.01, 8, kind="alignment")
    fd = np.gradient(z, x)[1:-1]
    rel = np.sqrt(np.mean((fd - s[1:-1]) ** 2) / np.mean(s**2))
    assert rel < 0.01
    # Slope variance is the spectral moment ∫ Ω²·G dΩ.
    _, _, s_long = track.fra_profile_with_slope(4, 20_000.0, 0.05, 9, kind="alignment")
    moment = band_integral(4, "alignment", weight=lambda w: w * w)
    assert np.var(s_long) == pytest.approx(moment, rel=0.02)


def test_time_input_grid_and_derivative():
    v, dt = track.class_speed(6), 1e-3
    t, z, zdot = track.track_time_input(6, v, 20.0, dt, 3)
    np.testing.assert_array_equal(t, np.arange(20001) * dt)
    assert z.dtype == zdot.dtype == np.float64 and z.shape == zdot.shape == t.shape
    fd = np.gradient(z, dt)[1:-1]
    assert np.sqrt(np.mean((fd - zdot[1:-1]) ** 2) / np.mean(zdot**2)) < 0.01
    inp = track.track_time_input(6, v, 20.0, dt, 3)
    assert isinstance(inp, track.TrackInput)
    np.testing.assert_array_equal(inp.z, z)


def test_time_input_variance_equals_profile_variance():
    _, z, zdot = track.track_time_input(5, 40.0, 1000.0, 5e-3, 12)
    assert np.var(z) == pytest.approx(band_integral(5), rel=0.02)
    moment = band_integral(5, weight=lambda w: w * w)
    assert np.var(zdot) == pytest.approx(40.0**2 * moment, rel=0.02)


def test_coarse_dt_samples_the_same_harmonic_sum():
    v = track.class_speed(6)  # v·dt = 0.98 m at 50 Hz: oversampled internally, not interpolated
    coarse = track.track_time_input(6, v, 20.0, 0.02, 21)
    fine = track.track_time_input(6, v, 20.0, 0.01, 21)
    np.testing.assert_allclose(coarse.z, fine.z[::2], rtol=0, atol=1e-12 * np.abs(fine.z).max())
    np.testing.assert_allclose(
        coarse.zdot, fine.zdot[::2], rtol=0, atol=1e-12 * np.abs(fine.zdot).max()
    )


def test_wheelbase_is_mean_of_two_wheels():
    v, dt, wheelbase = 40.0, 1e-3, 2.4
    lag = round(wheelbase / (v * dt))  # 60 samples
    both = track.track_time_input(5, v, 5.0, dt, 11, wheelbase=wheelbase)
    one = track.track_time_input(5, v, 5.0 + lag * dt, dt, 11)
    scale = np.abs(one.z).max()
    np.testing.assert_allclose(
        both.z, 0.5 * (one.z[:-lag] + one.z[lag:]), rtol=0, atol=1e-12 * scale
    )
    np.testing.assert_allclose(
        both.zdot,
        0.5 * (one.zdot[:-lag] + one.zdot[lag:]),
        rtol=0,
        atol=1e-12 * np.abs(one.zdot).max(),
    )


def test_wheelbase_filter_variance():
    wheelbase = 2.5
    _, z, _ = track.track_time_input(5, 40.0, 1000.0, 5e-3, 13, wheelbase=wheelbase)
    filtered = band_integral(5, weight=lambda w: np.cos(0.5 * w * wheelbase) ** 2)
    assert np.var(z) == pytest.approx(filtered, rel=0.02)


@pytest.mark.parametrize("bad", [7, 0, -1, "x", 3.0, True, None])
def test_bad_track_class(bad):
    with pytest.raises(ValueError, match="track_class"):
        track.fra_psd(1.0, bad)
    with pytest.raises(ValueError, match="track_class"):
        track.class_speed(bad)
    with pytest.raises(ValueError, match="track_class"):
        track.fra_profile(bad, 10.0, 0.05, 0)
    with pytest.raises(ValueError, match="track_class"):
        track.track_time_input(bad, 10.0, 1.0, 0.01, 0)


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: track.fra_psd(1.0, 3, "lateral"), "kind"),
        (lambda: track.fra_psd([1.0, 0.0], 3), "omega"),
        (lambda: track.fra_psd(np.nan, 3), "omega"),
        (lambda: track.fra_profile(3, -5.0, 0.05, 0), "length"),
        (lambda: track.fra_profile(3, 10.0, 0.6, 0), "dx"),
        (lambda: track.fra_profile(3, 10.0, 0.05, 0, (100.0, 1.0)), "band"),
        (lambda: track.fra_profile(3, 10.0, 0.05, 0, (1.0,)), "band"),
        (lambda: track.track_time_input(3, 0.0, 1.0, 0.01, 0), "speed"),
        (lambda: track.track_time_input(3, 10.0, math.inf, 0.01, 0), "duration"),
        (lambda: track.track_time_input(3, 10.0, 1.0, -0.01, 0), "dt"),
        (lambda: track.track_time_input(3, 10.0, 1.0, 0.01, 0, wheelbase=-2.5), "wheelbase"),
    ],
)
def test_bad_inputs_name_the_field(call, field):
    with pytest.raises(ValueError, match=field):
        call()


def _table_text(replace=("", "")):
    text = files("railgym").joinpath("configs", "track", "fra.yaml").read_text()
    assert replace[0] in text
    return text.replace(*replace, 1)


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        ("A_v: 0.6816, ", "", "classes.3.A_v"),
        ("A_a: 0.3027", "A_a: -0.3027", "classes.4.A_a"),
        ("Omega_s: 0.8209", "Omega_s: .nan", "classes.5.Omega_s"),
        ("max_speed: 176", "max_speed: fast", "classes.6.max_speed"),
        ("max_speed: km/h", "max_speed: mph", "units.max_speed"),
        ("k: 0.25", "k: 0", "k"),
    ],
)
def test_table_validation_names_field(tmp_path, old, new, field):
    path = tmp_path / "fra.yaml"
    path.write_text(_table_text((old, new)))
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        track.load_fra_table(path)


def test_table_round_trip_from_file(tmp_path):
    path = tmp_path / "fra.yaml"
    path.write_text(_table_text())
    assert track.load_fra_table(path) == track.load_fra_table()


def test_track_does_not_import_gymnasium():
    tree = ast.parse(Path(track.__file__).read_text())
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert imported and not any(m.split(".")[0] == "gymnasium" for m in imported)
