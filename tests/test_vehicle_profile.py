"""railgym.profile: reading, checking and resampling measured track profiles."""

import numpy as np
import pytest

from railgym.profile import check_profile, profile_time_input, read_profile_csv


def test_spline_resampling_reproduces_a_smooth_profile_and_its_rate(tmp_path):
    x = np.arange(0.0, 120.0, 0.5)
    lam = 12.0
    z = 1e-3 * np.sin(2 * np.pi * x / lam)
    path = tmp_path / "p.csv"
    rows = "".join(f"{a},{b!r}\n" for a, b in zip(x.tolist(), z.tolist(), strict=True))
    path.write_text("# measured\nx,z\n" + rows)
    xr, zr = read_profile_csv(path)
    np.testing.assert_array_equal(xr, x)
    speed, dt, n = 30.0, 1e-3, 3000
    zt, zdt = profile_time_input((xr, zr), speed, dt, n)
    t = np.arange(n) * dt
    w = 2 * np.pi * speed / lam
    # cubic spline error ~ (2π h/λ)⁴/384 of the amplitude for h = 0.5 m
    np.testing.assert_allclose(zt, 1e-3 * np.sin(w * t), atol=2e-3 * 1e-3)
    np.testing.assert_allclose(zdt, 1e-3 * w * np.cos(w * t), atol=1e-2 * 1e-3 * w)


def test_check_profile_names_the_index_without_a_file():
    with pytest.raises(ValueError, match="index 2"):
        check_profile([0, 1, 2, 3], [0, 0, np.inf, 0])
    with pytest.raises(ValueError, match="at least 4"):
        check_profile([0, 1], [0, 0])
    with pytest.raises(ValueError, match="too short"):
        profile_time_input(([0, 1, 2, 3], [0, 0, 0, 0]), 40.0, 1e-3, 1000)
