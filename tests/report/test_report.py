"""railgym.report: the quick report's tables and figures (run through ``railgym paper``), the
markdown tables, and the output-folder rules."""

from __future__ import annotations

import math

import numpy as np
import pytest

import agents.commands.cli
import railgym.report
from agents.commands.cli import main
from railgym.report import PAPER_LABEL, REPORT_FILES, make_report
from railgym.report.output import atomic_path, prepare_output_dir, write_text_atomic
from railgym.report.tables import markdown, table
from railgym.track import track_time_input
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate
from surrogates.models.lpr import LegendreRegression

#: bound on the out-of-bag relative RMS error of both models when Kriging beats LPR
OOB_NRMS_BOUND = 0.5


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """``railgym paper --quick --out paper`` in a folder that holds an empty ``paper/`` folder
    (``--out paper`` is that folder, and it is written); returns (folder, result, stdout)."""
    cwd = tmp_path_factory.mktemp("cwd")
    (cwd / "paper").mkdir()
    results = []

    def recorded(*args, **kwargs):
        results.append(make_report(*args, progress=False, **kwargs))
        return results[-1]

    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(cwd)
        mp.setattr(agents.commands.cli, "make_report", recorded)
        assert main(["paper", "--quick", "--out", "paper"]) == 0
    return cwd / "paper", results[0]


# ------------------------------------------------------------------------- the report
def test_quick_report_has_every_table_with_finite_numbers(quick):
    _, r = quick
    plan = r["plan"]
    assert plan["quick"] and plan["sizes"] == [51, 101] and plan["duration_s"] == 5.0
    t3 = r["table3"]
    assert t3["m"] == 101 and t3["n"] == 1001
    for kind in ("lpr", "kriging"):
        for key in ("oob_error", "oob_error_normalised", "oob_nrms"):
            assert math.isfinite(t3[kind][key]) and t3[kind][key] > 0
        assert set(t3["all_sizes"][kind]) == {51, 101}
    assert set(r["table5"]["lpr"]) == set(r["table5"]["kriging"]) == {51, 101}
    assert set(r["table8"]["classes"]) == {3, 4, 6}
    for kind in ("lpr", "kriging"):
        t8 = [c[kind] for c in r["table8"]["classes"].values()]
        for e in [*r["table5"][kind].values(), *t8]:
            # with the extrapolation guard neither element diverges on these tracks (the
            # paper's Kriging did on class 4); a diverged run would end early
            assert not e["diverged"] and e["t_end_s"] == pytest.approx(5.0)
            assert all(math.isfinite(e[q]) and e[q] > 0 for q in ("x", "v", "a"))
            assert e["evaluations"] == 4 * 5000 and 0 <= e["out_of_domain"] <= e["evaluations"]
    t6 = r["table6"]
    assert t6["reference_s"] > 0
    for kind in ("lpr", "kriging"):
        for e in t6[kind].values():
            assert e["T_t_fit_s"] > 0 and e["T_t_build_s"] >= e["T_t_fit_s"]
            assert e["predict_call_us"] > 0 and e["predict_point_us"] > 0
    for kind in ("lpr", "kriging"):
        assert all(e["T_s_numba_s"] > 0 for e in t6[kind].values())
    # Kriging costs O(M) per evaluation, LPR O(degree): its compiled run is the slower
    assert t6["kriging"][101]["T_s_numba_s"] > t6["lpr"][101]["T_s_numba_s"]
    t10 = r["table10"]["variants"]["paper"]
    assert set(t10) == {
        "wall_loading",
        "wall_unloading",
        "interface_loading",
        "interface_unloading",
    }
    for e in t10.values():
        assert 1 <= e["degree"] <= r["table10"]["max_degree"] and e["n_samples"] > e["degree"]
    t11 = r["table11"]["variants"]["paper"]
    for car in ("lead", "passenger"):
        assert all(math.isfinite(t11[car][q]) and t11[car][q] > 0 for q in ("x", "v", "a"))


def test_surrogates_track_the_reference(quick):
    """Eq. 9 errors well below the reference's own mean magnitude (a zero model scores 1)."""
    _, r = quick
    t5 = r["table5"]
    scale = t5["reference_mean_abs"]
    for e in t5["lpr"].values():
        for q in ("x", "v", "a"):
            assert e[q] < 0.6 * scale[q]
    # the crash surrogate's displacement error is a few cm on ~2 m of travel
    for car in ("lead", "passenger"):
        assert r["table11"]["variants"]["paper"][car]["x"] < 0.1


def test_lpr_oob_error_below_kriging_or_both_below_bound(quick):
    t3 = quick[1]["table3"]
    lpr, kr = t3["lpr"], t3["kriging"]
    assert lpr["oob_error_kind"] == kr["oob_error_kind"]
    assert lpr["oob_error"] < kr["oob_error"] or (
        lpr["oob_nrms"] < OOB_NRMS_BOUND and kr["oob_nrms"] < OOB_NRMS_BOUND
    )


def test_report_markdown_and_figures_exist(quick):
    out, r = quick
    text = (out / "report.md").read_text(encoding="utf-8")
    assert text == markdown(r)
    for title in ("Table 3", "Table 5", "Table 6", "Table 8", "Table 10", "Table 11"):
        assert f"## {title}" in text
    assert text.count(PAPER_LABEL) >= 6
    assert "diverged at" not in text and "No run diverged" in text
    assert len(r["figures"]) == 6
    assert sorted(p.name for p in out.iterdir()) == sorted(["report.md", *r["figures"]])
    for name in r["figures"]:
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000, name
        assert f"]({name})" in text


def test_report_reuses_its_own_folder_and_refuses_one_with_other_files(quick, monkeypatch, capsys):
    """One rule for ``paper`` and ``demo`` (:func:`prepare_output_dir` with the command's own
    files): the quick run's folder holds only report.md and the figures, so a second run
    writes them again; with another file in it, refused before any work naming that file,
    nothing changed, unless ``--overwrite`` (which keeps the other file)."""
    out, r = quick
    assert sorted(p.name for p in out.iterdir()) == sorted(REPORT_FILES)
    assert set(r["figures"]) <= set(REPORT_FILES)
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert main(["paper", "--quick", "--quiet", "--out", str(out)]) == 0
    again = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert set(again) == set(before) and all(again[n] > before[n] for n in before)
    assert "report written to" in capsys.readouterr().out
    (out / "notes.txt").write_text("mine")
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert main(["paper", "--quick", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "'notes.txt'" in err and "--overwrite" in err
    assert "Traceback" not in err
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before

    def work(*args, **kwargs):
        raise RuntimeError("the work started")

    monkeypatch.setattr(railgym.report, "compute", work)  # --overwrite: past the check
    assert main(["paper", "--quick", "--out", str(out), "--overwrite"]) == 1
    assert "the work started" in capsys.readouterr().err
    assert (out / "notes.txt").read_text() == "mine"
    (out / "notes.txt").unlink()


# ----------------------------------------------------------------------- the pieces
def test_lpr_of_the_linear_law_reproduces_the_linear_suspension():
    """The report's LPR path is the compiled ``surrogate`` kernel: an LPR of degree 1 fitted on
    F = k2·δ + c2·δ̇ is that law everywhere (linear extrapolation), so it must give the
    ``linear`` variant's response."""
    vehicle = load_vehicle("manchester")
    rng = np.random.default_rng(1)
    U = rng.uniform([-0.02, -0.2], [0.02, 0.2], size=(50, 2))
    model = LegendreRegression(degree=1).fit(U, vehicle.k2 * U[:, 0] + vehicle.c2 * U[:, 1])
    _, z, zdot = track_time_input(4, 128 / 3.6, 2.0, 1e-3, seed=3)
    got = simulate("surrogate", vehicle, z, zdot, 1e-3, surrogate=model, sample_every=5)
    ref = simulate("linear", vehicle, z, zdot, 1e-3, sample_every=5)
    assert got["out_of_domain"] > 0  # class 4 leaves the small box: extrapolation is exercised
    for key in ("x1", "v1", "x2", "v2", "a1", "a2", "F_s"):
        scale = np.max(np.abs(ref[key]))
        np.testing.assert_allclose(got[key], ref[key], rtol=0, atol=1e-9 * scale, err_msg=key)


def test_markdown_table():
    assert (
        table(["a", "b"], [["1", "2"], ["3", "4"]])
        == "| a | b |\n|---|---|\n| 1 | 2 |\n| 3 | 4 |\n"
    )


def test_output_folder_rules(tmp_path):
    assert prepare_output_dir(tmp_path / "new" / "deep") == tmp_path / "new" / "deep"
    (tmp_path / "f").write_text("x")
    with pytest.raises(ValueError, match="--out .*not a folder"):
        prepare_output_dir(tmp_path / "f", overwrite=True)
    with pytest.raises(ValueError, match="--dir .*not empty"):
        prepare_output_dir(tmp_path, flag="--dir")
    with pytest.raises(ValueError, match="cannot create"):
        prepare_output_dir(tmp_path / "f" / "sub")


def test_atomic_write_replaces_or_keeps_the_old_file(tmp_path):
    path = tmp_path / "r.md"
    write_text_atomic(path, "old")
    write_text_atomic(path, "new ü")
    assert path.read_text(encoding="utf-8") == "new ü"
    with pytest.raises(RuntimeError), atomic_path(path) as tmp:
        tmp.write_text("half")
        raise RuntimeError("interrupted")
    assert path.read_text(encoding="utf-8") == "new ü"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.md"]


def test_make_report_checks_seed_and_folder_before_work(tmp_path):
    with pytest.raises(ValueError, match="seed"):
        make_report(tmp_path, seed=True)
    (tmp_path / "x").write_text("keep")
    with pytest.raises(ValueError, match="not empty"):
        make_report(tmp_path, quick=True)
    assert [p.name for p in tmp_path.iterdir()] == ["x"]


def test_quick_report_has_the_validation_matrix(quick):
    """4 classes × 3 controllers × {static, memory}; the memory element is the closer one on
    every cell of the quick run (2 unseen tracks of 5 s), as in docs/validation.md."""
    folder, r = quick
    v = r["validation"]
    assert v["settings"]["n_seeds"] == 2 and v["settings"]["duration"] == 5.0
    cells = {(x["element"], x["class"], x["controller"]): x for x in v["rows"]}
    assert len(cells) == 2 * 4 * 3
    for (element, cls, ctrl), row in cells.items():
        assert row["diverged"] == 0 and 0 < row["median"] <= row["p90"] <= row["max"]
        if element == "memory":
            assert row["median"] < cells["static", cls, ctrl]["median"]
    assert "## Validation matrix" in (folder / "report.md").read_text()


def test_crash_element_curves_are_drawn_only_near_their_data():
    """Figs. 13-14 break a branch's curve where it has no data (the interface unloading
    branch has data at both ends of its box only)."""
    from railgym.report.figures import _near

    data = np.array([0.0, 0.001, 0.002, 0.57, 0.58])
    x = np.linspace(0.0, 0.58, 59)
    near = _near(x, data, 0.0058)
    assert np.flatnonzero(near).tolist() == [0, 57, 58]  # u = 0, 0.57, 0.58 m
    assert _near(np.array([0.3]), np.array([0.3]), 0.0).all()


def test_fig11_shows_the_papers_errors_beside_ours():
    plt = pytest.importorskip("matplotlib.pyplot")
    from types import SimpleNamespace

    from railgym.report.figures import _errors
    from railgym.report.published import PAPER

    sizes = (51, 101, 7)  # 7: a size the paper does not give
    ours = {
        kind: {m: {"x": k * 1e-4 * m, "v": k * 1e-3 * m, "a": k * 1e-2 * m} for m in sizes}
        for k, kind in ((1.0, "lpr"), (2.0, "kriging"))
    }
    table5 = {**ours, "published": PAPER["table5"]}
    fig = _errors(plt, table5, SimpleNamespace(sizes=sizes))
    for i, (ax, q) in enumerate(zip(fig.axes, "xva", strict=True)):
        bars = [p.get_height() for p in ax.patches]
        for j, kind in enumerate(("lpr", "kriging")):  # ours, then the paper's, per element
            mine, paper = bars[6 * j : 6 * j + 3], bars[6 * j + 3 : 6 * j + 6]
            assert mine == [ours[kind][m][q] for m in sizes]
            assert paper[:2] == [PAPER["table5"][kind][m][i] for m in (51, 101)]
            assert np.isnan(paper[2])
    plt.close(fig)
