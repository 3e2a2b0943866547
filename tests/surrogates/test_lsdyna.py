"""LS-DYNA ASCII readers: hand-written fixtures in the documented layouts, parsed to SI."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from surrogates import io
from surrogates.lsdyna import NODOUT_FIELDS, write_nodout, write_rcforc

DATA = Path(__file__).resolve().parents[1] / "data"
# SI value of one unit of (length, time, mass-free force, energy) per unit set, by hand
SCALES = {
    "m-s-kg-N": {"L": 1.0, "T": 1.0, "F": 1.0, "E": 1.0},
    "mm-s-t-N": {"L": 1e-3, "T": 1.0, "F": 1.0, "E": 1e-3},
    "mm-ms-kg-kN": {"L": 1e-3, "T": 1e-3, "F": 1e3, "E": 1.0},
}


def _read(reader, *args, **kw):
    with pytest.warns(UserWarning, match="truncated last block"):
        return reader(*args, **kw)


@pytest.mark.parametrize("units", list(SCALES))
def test_nodout_fixture_in_si(units):
    s = SCALES[units]
    L, T = s["L"], s["T"]
    nodes = _read(io.read_nodout, DATA / "nodout_sled", units=units)
    assert sorted(nodes) == [101, 1234567890]
    lead, car2 = nodes[101], nodes[1234567890]
    # three complete blocks: the fourth stops inside the second node's line
    np.testing.assert_allclose(lead.t, np.array([0.0, 1.0, 2.0]) * T, rtol=1e-15)
    np.testing.assert_allclose(lead["x_disp"], np.array([0.0, 10.0, 18.0]) * L, rtol=1e-15)
    np.testing.assert_allclose(lead["x_vel"], np.array([11.111, 9.0, 7.0]) * L / T, rtol=1e-15)
    np.testing.assert_allclose(lead["x_accl"], np.array([0.0, -2.0, -2.0]) * L / T**2)
    assert lead["z_accl"][1] == pytest.approx(1.2345e-105 * L / T**2, rel=1e-12)  # lost 'E'
    np.testing.assert_allclose(lead["x_coor"], np.array([1000.0, 1010.0, 1018.0]) * L)
    # 10-digit node id and 12-character values running together, parsed by offset
    np.testing.assert_allclose(car2["x_disp"], np.array([-1.0, -2.0, -3.0]) * L, rtol=1e-15)
    row = [car2[f][0] for f in NODOUT_FIELDS]
    expected = np.array([-1.0, 2.5, -3.0, 11.111, -0.4, 0.5, -60.0, 70.0, -80.0, -2.5e4, 100, 0])
    factors = np.repeat([L, L / T, L / T**2, L], 3)
    np.testing.assert_allclose(row, expected * factors, rtol=1e-15)
    assert lead.units["x_vel"] == "m/s" and lead.units["x_accl"] == "m/s^2"


def test_nodout_node_selection_and_legend():
    nodes = _read(io.read_nodout, DATA / "nodout_sled", nodes=[1234567890])
    assert list(nodes) == [1234567890]
    assert io.read_legend(DATA / "nodout_sled") == {
        101: "lead car centre of mass",
        1234567890: "car 2 centre of mass",
    }
    with pytest.raises(ValueError, match=r"node\(s\) \[7\] not in the file"):
        io.read_nodout(DATA / "nodout_sled", nodes=[7])


@pytest.mark.parametrize("units", list(SCALES))
def test_rcforc_fixture_in_si(units):
    F, T = SCALES[units]["F"], SCALES[units]["T"]
    forces = _read(io.read_rcforc, DATA / "rcforc_sled", units=units)
    assert sorted(forces) == [("master", 1), ("master", 2), ("slave", 1), ("slave", 2)]
    wall = forces[("master", 1)]
    np.testing.assert_allclose(wall.t, np.array([0.0, 1.0, 2.0]) * T)
    np.testing.assert_allclose(wall["x_force"], np.array([0.0, -1500.0, -1234.5]) * F)
    np.testing.assert_allclose(wall["y_force"], np.array([0.0, 30.0, 0.0]) * F)
    res = np.array([0.0, np.sqrt(1500.0**2 + 30.0**2 + 40.0**2), 1234.5]) * F
    np.testing.assert_allclose(wall["resultant"], res, rtol=1e-15)
    np.testing.assert_allclose(forces[("slave", 2)]["x_force"], np.array([0, -200, -600.0]) * F)
    assert io.read_legend(DATA / "rcforc_sled")[2] == "lead car to car 2"


@pytest.mark.parametrize("units", list(SCALES))
def test_glstat_fixture_energy_balance_in_si(units):
    E, T = SCALES[units]["E"], SCALES[units]["T"]
    g = _read(io.read_glstat, DATA / "glstat_sled", units=units)
    np.testing.assert_allclose(g.t, np.array([0.0, 1.0, 2.0]) * T)
    np.testing.assert_allclose(g["kinetic_energy"], np.array([1e6, 6e5, 2e5]) * E)
    np.testing.assert_allclose(g["stonewall_energy"], np.array([0, 2e4, 4e4]) * E)  # 2 walls
    np.testing.assert_allclose(g["time_step"], np.full(3, 1e-4 * T))
    parts = (
        "kinetic_energy",
        "internal_energy",
        "hourglass_energy",
        "sliding_interface_energy",
        "stonewall_energy",
        "spring_and_damper_energy",
    )
    np.testing.assert_allclose(sum(g[p] for p in parts), g["total_energy"], rtol=1e-12)
    assert "global_x_velocity" not in g
    assert g.units["total_energy"] == "J"


def _nodout_text(blocks):
    t = np.arange(blocks, dtype=float)
    return t, {5: {"x_disp": t * 2.0, "x_vel": t + 1.0}, 9: {"x_disp": -t}}


def test_bad_files_name_file_line_and_field(tmp_path):
    t, nodes = _nodout_text(3)
    good = write_nodout(tmp_path / "nodout", t, nodes)
    text = good.read_text().splitlines()
    # a non-numeric field: line and columns of the field in the message
    i = next(k for k, line in enumerate(text) if line.startswith("         9"))
    bad = text.copy()
    bad[i] = bad[i][:22] + "  abcdefghij" + bad[i][34:]
    (tmp_path / "bad").write_text("\n".join(bad) + "\n")
    with pytest.raises(ValueError, match=rf"bad: line {i + 1}: field 'y_disp' \(columns 23-34\)"):
        io.read_nodout(tmp_path / "bad")
    # time going backwards
    back = good.read_text().replace("( at time 2.0000000E+00 )", "( at time 5.0000000E-01 )")
    (tmp_path / "back").write_text(back)
    with pytest.raises(ValueError, match=r"back: line \d+: block time 0.5 is not after"):
        io.read_nodout(tmp_path / "back")
    # empty file, unknown unit set
    (tmp_path / "empty").write_text("")
    with pytest.raises(ValueError, match="empty: no 'n o d a l"):
        io.read_nodout(tmp_path / "empty")
    with pytest.raises(ValueError, match="units 'in-s-lbf' is not a known"):
        io.read_nodout(good, units="in-s-lbf")
    # a block cut short in the middle of the file is an error, not a warning
    mid = text.copy()
    del mid[[k for k, line in enumerate(text) if line.startswith("         9")][1]]
    (tmp_path / "mid").write_text("\n".join(mid) + "\n")
    with pytest.raises(ValueError, match="incomplete but more blocks follow"):
        io.read_nodout(tmp_path / "mid")
    with pytest.raises(ValueError, match=r"rc: line 3: field 'x_force' \(after the label 'x'\)"):
        path = write_rcforc(tmp_path / "rc", t, {("master", 1): {"x_force": t}})
        lines = path.read_text().splitlines()
        lines[2] = lines[2][:40] + "   1.2.3E+00" + lines[2][52:]
        path.write_text("\n".join(lines) + "\n")
        io.read_rcforc(path)


@settings(max_examples=25, deadline=None)
@given(
    values=st.lists(
        st.floats(min_value=-1e30, max_value=1e30, allow_nan=False, allow_subnormal=False),
        min_size=6,
        max_size=6,
    ),
    node=st.integers(min_value=1, max_value=999_999_999),
)
def test_written_nodout_reads_back_to_its_printed_precision(tmp_path_factory, values, node):
    tmp = tmp_path_factory.mktemp("rt")
    t = np.array([0.0, 1e-3])
    v = np.array(values).reshape(2, 3)
    fields = {"x_disp": v[:, 0], "y_vel": v[:, 1], "z_accl": v[:, 2]}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        th = io.read_nodout(write_nodout(tmp / "n", t, {node: fields}))[node]
    for name, col in fields.items():
        np.testing.assert_allclose(th[name], col, rtol=5.1e-5, atol=1e-300)  # 5 digits


_PEAK = """
import resource, sys
from surrogates.io import read_nodout
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
nodes = None if sys.argv[2] == "all" else [1, 100]
out = read_nodout(sys.argv[1], nodes=nodes)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(len(out), len(out[1]), base, peak)
"""


@pytest.mark.slow
def test_a_200_mb_nodout_is_streamed(tmp_path):
    """200 MB of nodout (100 nodes, 12 700 blocks): the reader's peak memory is that of the
    values kept (measured figures in docs/data.md), not of the file."""
    import subprocess
    import sys

    n_nodes, n_blocks = 100, 12_700
    t = np.arange(n_blocks) * 1e-5
    rng = np.random.default_rng(0)
    path = tmp_path / "nodout"
    cols = {f: rng.standard_normal(n_blocks) for f in NODOUT_FIELDS}
    write_nodout(path, t, dict.fromkeys(range(1, n_nodes + 1), cols))
    size = path.stat().st_size
    assert size > 200e6
    root = Path(__file__).resolve().parents[2]
    peaks = {}
    for which in ("two", "all"):
        res = subprocess.run(
            [sys.executable, "-c", _PEAK, str(path), which],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
        )
        n, samples, base, peak = map(int, res.stdout.split())
        assert samples == n_blocks
        peaks[which] = (peak - base) * 1024  # ru_maxrss is in KiB on Linux
    kept_all = n_nodes * n_blocks * 13 * 8  # 12 fields + time, float64
    print(
        f"file {size / 1e6:.0f} MB; extra peak RSS: 2 nodes {peaks['two'] / 1e6:.1f} MB, "
        f"all nodes {peaks['all'] / 1e6:.0f} MB (values kept {kept_all / 1e6:.0f} MB)"
    )
    assert peaks["two"] < 0.05 * size
    assert peaks["all"] < 2.5 * kept_all


def _has_lasso() -> bool:
    import importlib.util

    return importlib.util.find_spec("lasso") is not None


@pytest.mark.skipif(_has_lasso(), reason="lasso-python is installed")
def test_binout_without_lasso_is_a_clear_import_error(tmp_path):
    with pytest.raises(ImportError, match="read_binout needs lasso-python"):
        io_binout(tmp_path / "binout")


def io_binout(path, **kw):
    from surrogates.lsdyna import read_binout

    return read_binout(path, **kw)


def test_binout_read_through_lasso(tmp_path):
    """binout written with lasso's own LSDA writer, read back in SI (mm-ms-kg-kN)."""
    lsda = pytest.importorskip(
        "lasso.dyna.lsda_py3", reason="lasso-python (the 'lsdyna' extra) is not installed"
    )
    Lsda = lsda.Lsda
    path = str(tmp_path / "binout")
    f = Lsda(path, "w")
    f.cd("/nodout/metadata")
    f.write("ids", Lsda.I4, [101, 202])
    f.cd("/rcforc/metadata")
    f.write("ids", Lsda.I4, [1, 1])
    f.write("side", Lsda.I4, [1, 0])
    for k in range(3):
        f.cd(f"/nodout/d{k + 1:06d}")
        f.write("time", Lsda.R8, [float(k)])
        for name in ("displacement", "velocity", "acceleration", "coordinate"):
            for axis in "xyz":
                f.write(f"{axis}_{name}", Lsda.R4, [10.0 * k, -1.0 * k])
        f.cd(f"/rcforc/d{k + 1:06d}")
        f.write("time", Lsda.R4, [float(k)])
        for axis in "xyz":
            f.write(f"{axis}_force", Lsda.R4, [2.0 * k, -2.0 * k])
        f.cd(f"/glstat/d{k + 1:06d}")
        f.write("time", Lsda.R4, [float(k)])
        for name in ("kinetic_energy", "internal_energy", "total_energy"):
            f.write(name, Lsda.R4, [100.0 - k])
    f.close()
    data = io_binout(path, units="mm-ms-kg-kN")
    node = data.nodout[101]
    np.testing.assert_allclose(node.t, [0.0, 1e-3, 2e-3])
    np.testing.assert_allclose(node["x_disp"], [0.0, 0.01, 0.02])  # mm → m
    np.testing.assert_allclose(data.nodout[202]["y_accl"], [0.0, -1e3, -2e3])  # mm/ms² → m/s²
    np.testing.assert_allclose(data.rcforc[("master", 1)]["x_force"], [0.0, 2e3, 4e3])
    np.testing.assert_allclose(data.rcforc[("slave", 1)]["z_force"], [0.0, -2e3, -4e3])
    np.testing.assert_allclose(data.glstat["total_energy"], [100.0, 99.0, 98.0])  # kN·mm = J


MOMENTS = " mx  1.0E+00 my  0.0E+00 mz  0.0E+00"
RCFORC_LABELLED = f""" rcforc written by another LS-DYNA version: other widths, moments
{{BEGIN LEGEND}}
 Entity #        Title
        7     wall
{{END LEGEND}}
 master      7 time  1.00E-03  x  1.50E+01  y -2.00E+00  z  3.00E+00 mass  0.00E+00{MOMENTS}
 slave      7 time  1.00E-03  x -1.50E+01  y  2.00E+00  z -3.00E+00
 master      7 time  2.00E-03  x  3.00E+01  y -4.00E+00  z  6.00E+00 mass  0.00E+00{MOMENTS}
 slave      7 time  2.00E-03  x -3.00E+01  y  4.00E+00  z -6.00E+00
 master      1234567 time-1.00000000E-03  x-1.0E+00  y 0.0  z 0.0
 master      1234567 time 1.00000000E-03  x-2.0E+00  y 0.0  z 0.0
"""


def test_rcforc_is_parsed_by_its_labels_in_any_widths(tmp_path):
    path = tmp_path / "rcforc"
    path.write_text(RCFORC_LABELLED)
    data = io.read_rcforc(path, units="mm-ms-kg-kN")  # kN, ms
    assert sorted(data) == [("master", 7), ("master", 1234567), ("slave", 7)]
    m = data[("master", 7)]
    np.testing.assert_allclose(m.t, [1e-6, 2e-6])
    np.testing.assert_allclose(m["x_force"], [1.5e4, 3e4])
    np.testing.assert_allclose(
        m["resultant"], 1e3 * np.hypot(np.hypot(15, 2), 3) * np.array([1, 2])
    )
    np.testing.assert_allclose(data[("slave", 7)]["z_force"], [-3e3, -6e3])
    np.testing.assert_allclose(data[("master", 1234567)]["x_force"], [-1e3, -2e3])
    # the fixed-width layout of write_rcforc reads the same values
    t = np.array([1e-3, 2e-3])
    fixed = write_rcforc(tmp_path / "fixed", t, {("master", 7): {"x_force": [15.0, 30.0]}})
    np.testing.assert_allclose(io.read_rcforc(fixed)[("master", 7)]["x_force"], [15.0, 30.0])


def test_rcforc_line_without_a_force_label_is_cut_short(tmp_path):
    path = tmp_path / "rcforc"
    lines = RCFORC_LABELLED.splitlines()
    path.write_text("\n".join([*lines, " master      7 time  3.00E-03  x  1.0E+00"]) + "\n")
    with pytest.warns(UserWarning, match="truncated last block at line 12"):
        assert io.read_rcforc(path)[("master", 7)].t.size == 2
    path.write_text("\n".join([*lines[:6], lines[6][:40], lines[7]]) + "\n")
    with pytest.raises(ValueError, match="line 7: line too short for the rcforc layout"):
        io.read_rcforc(path)


def test_nodes_given_as_a_string_is_refused(tmp_path):
    with pytest.raises(
        ValueError, match=r"nodes must be a list of node ids \(integers\), got '12'"
    ):
        io.read_nodout(DATA / "nodout_sled", nodes="12")
    with pytest.raises(ValueError, match=r"nodes must be node ids \(integers\), got 1\.5"):
        io.read_nodout(DATA / "nodout_sled", nodes=[1.5])


def test_a_missing_end_legend_is_named(tmp_path):
    text = (DATA / "rcforc_sled").read_text().replace("{END LEGEND}\n", "")
    (tmp_path / "rc").write_text(text)
    with pytest.raises(ValueError, match=r"rc: line 8: 'master .* has no \{END LEGEND\} line"):
        io.read_legend(tmp_path / "rc")


def test_a_title_in_another_encoding_does_not_stop_the_reader(tmp_path):
    raw = (DATA / "rcforc_sled").read_bytes().replace(b"wall to lead car", b"mur \xe0 voiture")
    (tmp_path / "rc").write_bytes(raw)
    assert io.read_legend(tmp_path / "rc")[1] == "mur \ufffd voiture"
    assert io.read_rcforc(tmp_path / "rc").keys() == io.read_rcforc(DATA / "rcforc_sled").keys()


def test_a_value_whose_si_conversion_overflows_names_file_and_line(tmp_path):
    text = RCFORC_LABELLED.replace("x  3.00E+01", "x  3.00+307")
    (tmp_path / "rc").write_text(text)
    with pytest.raises(ValueError, match=r"rc: line 8: field 'x_force' .* beyond"):
        io.read_rcforc(tmp_path / "rc", units="mm-ms-kg-kN")
