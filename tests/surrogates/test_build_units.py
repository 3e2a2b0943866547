"""``surrogates build`` converts the table's units to SI (``du [mm]``, ``F [kN]`` or
``--units``), as :func:`surrogates.tables.read_table` converts, and says so."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from surrogates import io
from surrogates.cli import main
from surrogates.tables import UNITS, to_si


def _law(du: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """A damper with a spring: N at m, m/s."""
    return 4.0e5 * du + 1.5e4 * dv + 2.0e4 * dv * np.abs(dv)


def _table(path: Path, header: str, scale: tuple[float, float, float]) -> Path:
    rng = np.random.default_rng(4)
    du, dv = rng.uniform(-0.04, 0.04, 300), rng.uniform(-0.3, 0.3, 300)
    f = _law(du, dv)
    rows = [
        f"{a * scale[0]:.17g},{b * scale[1]:.17g},{c * scale[2]:.17g}"
        for a, b, c in zip(du, dv, f, strict=True)
    ]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _build(data: Path, out: Path, *extra: str) -> int:
    argv = ["build", str(data), "--inputs", "du", "dv", "--target", "F", "-o", str(out)]
    return main([*argv, "--m", "80", "--degree", "1", "2", "--seed", "3", *extra])


def test_unit_headers_are_converted_to_si(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    si = _table(tmp_path / "si.csv", "du [m],dv [m/s],F [N]", (1.0, 1.0, 1.0))
    mm = _table(tmp_path / "mm.csv", "du [mm],dv [mm/s],F [kN]", (1e3, 1e3, 1e-3))
    flag = _table(tmp_path / "flag.csv", "du,dv,F", (1e3, 1e3, 1e-3))
    assert _build(si, tmp_path / "si.json") == 0
    assert "converted to SI" not in capsys.readouterr().err
    assert _build(mm, tmp_path / "mm.json") == 0
    err = capsys.readouterr().err
    assert (
        "converted to SI: du mm -> m (x 0.001), dv mm/s -> m/s (x 0.001), F kN -> N (x 1000)" in err
    )
    assert _build(flag, tmp_path / "flag.json", "--units", "du=mm", "dv=mm/s", "F=kN") == 0
    ref = io.load(tmp_path / "si.json")
    u = np.column_stack([np.linspace(-0.03, 0.03, 7), np.linspace(-0.2, 0.25, 7)])
    for name in ("mm.json", "flag.json"):
        model = io.load(tmp_path / name)
        assert model.features_["units"] == {"du": "m", "dv": "m/s", "F": "N"}
        np.testing.assert_allclose(model.predict(u), ref.predict(u), rtol=1e-9, atol=1e-6)
    # the law itself (degree 1 in du, 2 in dv: |dv|·dv is not a polynomial, so within 3 %)
    law = _law(u[:, 0], u[:, 1])
    assert np.sqrt(np.mean((ref.predict(u) - law) ** 2) / np.mean(law**2)) < 0.03


def test_to_si_uses_the_table_factors_and_keeps_si_units() -> None:
    cols = {"a": np.array([1.0, 2.0]), "b": np.array([3.0]), "c": np.array([5.0])}
    out, units, factors = to_si(cols, {"a": "kN", "b": "N/m", "c": "deg"}, "x")
    assert units == {"a": "N", "b": "N/m", "c": "rad"}
    np.testing.assert_array_equal(out["a"], [1e3, 2e3])
    assert out["b"] is cols["b"] and factors == {"a": 1e3, "c": UNITS["deg"][0]}
    with pytest.raises(ValueError, match="x: column 'a' overflows"):
        to_si({"a": np.array([1e306])}, {"a": "MN"}, "x")
