"""Multibody time-history tables: reader options, bad files, recipe to a vertical element."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from railgym.vehicles.collect import collect_vertical
from railgym.vehicles.vertical.params import load_vehicle
from surrogates import io
from surrogates.builder import build
from surrogates.features import vertical_features_from
from surrogates.tables import read_table

COLS = ("Time", "z_bogie", "z_body", "v_bogie", "v_body", "a_body")


def _simpack_like(path, rec, n=None):
    """A whitespace table with a preamble, a header and a unit row, in mm, mm/s and g."""
    n = rec["t"].size if n is None else n
    lines = [
        "! exported by a multibody tool",
        "! channel list follows",
        "  ".join(COLS),
        "s mm mm mm/s mm/s g",
    ]
    for i in range(n):
        row = (
            rec["t"][i],
            rec["x1"][i] * 1e3,
            rec["x2"][i] * 1e3,
            rec["v1"][i] * 1e3,
            rec["v2"][i] * 1e3,
            rec["a2"][i] / 9.80665,
        )
        lines.append("  ".join(f"{v:.10e}" for v in row))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def record():
    return collect_vertical(duration=6.0)


def test_recipe_multibody_table_to_a_vertical_element(record, tmp_path):
    path = _simpack_like(tmp_path / "bogie.txt", record)
    th = read_table(path, header_row=2, unit_row=3, time="Time")
    assert th.units["z_bogie"] == "m" and th.units["a_body"] == "m/s^2"
    m2 = load_vehicle("manchester").m2
    U, V = vertical_features_from(
        th, m2, x1="z_bogie", x2="z_body", v1="v_bogie", v2="v_body", a2="a_body"
    )
    np.testing.assert_allclose(U, record["U"], rtol=1e-9, atol=1e-11)  # 11 digits printed
    np.testing.assert_allclose(V, record["V"], rtol=1e-9, atol=1e-9)
    model, _ = build(U, V, m=61, sampling="random", seed=0)
    direct, _ = build(record["U"], record["V"], m=61, sampling="random", seed=0)
    np.testing.assert_allclose(model.predict(U), direct.predict(U), rtol=1e-6, atol=1e-3)
    element = io.save(
        model,
        tmp_path / "element.json",
        inputs=["x1-x2", "v1-v2"],
        output="m2*a2",
        units={"x1-x2": "m", "v1-v2": "m/s", "m2*a2": "N"},
    )
    env = gym.make("railgym/VerticalSuspension-v1", surrogate=str(element), duration=1.0)
    env.reset(seed=0)
    for _ in range(100):
        obs, r, term, trunc, _ = env.step(np.zeros(env.action_space.shape, np.float32))
        assert np.all(np.isfinite(obs)) and np.isfinite(r)
        if term or trunc:
            break


def test_delimiters_units_in_names_and_overrides(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("t [ms];x (mm);F/kN;F2\n0;1;2;3\n1;2;4;6\n2;3;6;9\n")
    th = read_table(p, units={"F2": "MN"})
    np.testing.assert_allclose(th.t, [0.0, 1e-3, 2e-3])
    np.testing.assert_allclose(th["x"], [1e-3, 2e-3, 3e-3])
    np.testing.assert_allclose(th["F2"], [3e6, 6e6, 9e6])
    assert "F/kN" in th  # '/unit' is not a bracket: kept as a name, no unit
    q = tmp_path / "b.tsv"
    q.write_text("# comment\ntime\tq\n\n0\t1\n0.5\t2\n")
    th = read_table(q, header_row=1, time="time", delimiter="tab", columns=["q"])
    np.testing.assert_allclose(th["q"], [1.0, 2.0])


@pytest.mark.parametrize(
    "text, match",
    [
        ("", "empty file"),
        ("t,x\n0,1\n1,abc\n", r"line 3: column 'x': 'abc' is not a number"),
        ("t,x\n0,1\n1,2,3\n", "line 3 has 3 fields, the header has 2"),
        ("t,x\n0,1\n2,2\n1,3\n", r"line 4: time 1.0 does not increase"),
        ("t,x\n0,1\n1,nan\n", "line 3: column 'x': value is nan"),
        ("t,y\n0,1\n1,2\n", r"missing column\(s\) \['x'\]"),
        ("time,x\n0,1\n1,2\n", "no time column 't'"),
        ("t,x\n0,1\n1\n2,3\n", "line 3 has fewer fields than the header"),
        ("t [fortnight],x\n0,1\n1,2\n", "unit 'fortnight' of column 't' is not known"),
        ("t,x\n0,1\n", "fewer than 2 data rows"),
    ],
)
def test_bad_tables_name_file_line_and_column(tmp_path, text, match):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(ValueError, match=match):
        read_table(p, columns=["x"])


def test_truncated_last_row_is_dropped_with_a_warning(tmp_path):
    p = tmp_path / "cut.csv"
    p.write_text("t,x,y\n0,1,2\n1,2,3\n2,3")
    with pytest.warns(UserWarning, match=r"last row \(line 4\) is cut short"):
        th = read_table(p)
    assert len(th) == 2
