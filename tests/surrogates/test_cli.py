import json
import re
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from surrogates import io
from surrogates.cli import main


def _write_csv(path, n=300, seed=0):
    rng = np.random.default_rng(seed)
    du, dv = rng.uniform(-0.02, 0.02, n), rng.uniform(-0.2, 0.2, n)
    force = 8.6e5 * du + 4e4 * dv + 1e8 * du**3
    data = np.column_stack([np.arange(n) * 0.02, du, dv, force])
    rows = "\n".join(",".join(repr(float(x)) for x in r) for r in data)
    path.write_text("t,du,dv,F\n" + rows + "\n")
    return np.column_stack([du, dv]), force


def _build_args(tmp_path, *extra):
    return [
        "build",
        str(tmp_path / "d.csv"),
        "--inputs",
        "du",
        "dv",
        "--target",
        "F",
        "-o",
        str(tmp_path / "m.json"),
        "--m",
        "61",
        "--sampling",
        "greedy",
        "--quiet",
        "--overwrite",
        *extra,
    ]


def test_build_command_writes_a_loadable_model(tmp_path, capsys):
    U, F = _write_csv(tmp_path / "d.csv")
    out, rep = tmp_path / "m.json", tmp_path / "r.json"  # the -o of _build_args
    code = main(_build_args(tmp_path, "--units", "du=m", "dv=m/s", "F=N", "--report", str(rep)))
    assert code == 0
    model = io.load(out)
    lo, hi = model.domain_
    inside = np.all((U >= lo) & (U <= hi), axis=1)
    assert inside.mean() > 0.95
    np.testing.assert_allclose(model.predict(U[inside]), F[inside], rtol=1e-8, atol=1e-6)
    assert model.features_["inputs"] == ["du", "dv"] and model.features_["units"]["F"] == "N"
    assert model.features_["units"] == {"du": "m", "dv": "m/s", "F": "N"}
    assert json.loads(rep.read_text())["m"] == 61
    out = capsys.readouterr().out
    assert "chosen" in out
    # the error in the output's unit (--units F=N), the relative RMS dimensionless
    assert re.search(r"OOB error \(eq\. 9 absolute\) = \S+ N   OOB relative RMS = \S+ \(dim", out)


def test_build_command_reports_a_missing_column(tmp_path, capsys):
    _write_csv(tmp_path / "d.csv")
    code = main(
        [
            "build",
            str(tmp_path / "d.csv"),
            "--inputs",
            "du",
            "x",
            "--target",
            "F",
            "-o",
            str(tmp_path / "m.json"),
            "--quiet",
        ]
    )
    assert code == 2 and "missing column" in capsys.readouterr().err


def test_railgym_command_has_demo_paper_evaluate():
    from agents.commands.cli import main as railgym_main

    with pytest.raises(SystemExit) as exc:
        railgym_main(["--help"])
    assert exc.value.code == 0


def test_demo_passes_the_surrogate_only_to_its_backend_and_warns_nothing(
    tmp_path, monkeypatch, capsys
):
    """Every warning is an error: the reference runs get no ``surrogate=``; skyhook lowers the
    weighted carbody acceleration on both models, and the plots are written."""
    import warnings

    from agents.commands import cli
    from railgym.vehicles.collect import build_vertical_surrogate

    def quick_build(m, **kwargs):  # a smaller, faster build of the same element
        return build_vertical_surrogate(m=41, sampling="greedy", **kwargs)

    monkeypatch.setattr(cli, "build_vertical_surrogate", quick_build)
    figures = []
    mpl = pytest.importorskip("matplotlib.figure")
    save = mpl.Figure.savefig

    def keep(fig, path, **kw):
        figures.append((Path(path).name, fig))
        return save(fig, path, **kw)

    monkeypatch.setattr(mpl.Figure, "savefig", keep)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cli.main(["demo", "--out", str(tmp_path / "d"), "--seed", "2"]) == 0
    out = capsys.readouterr().out
    # units in the headers and the OOB line
    assert "RMS ẍ2 m/s²" in out and "a_w Wk m/s²" in out and "Sperling Wz" in out
    assert re.search(r"OOB error \(eq\. 9 absolute\) = \S+ N ", out)
    # fig. 9 of the demo: under each controller the difference surrogate − reference
    fig = dict(figures)["carbody_acceleration.png"]
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["ẍ2 (m/s²)", "Δẍ2 (m/s²)"] * 2
    for top, diff in (fig.axes[0:2], fig.axes[2:4]):
        ref, sur = (line.get_ydata() for line in top.get_lines()[:2])
        np.testing.assert_allclose(diff.get_lines()[0].get_ydata(), sur - ref, rtol=0, atol=0)
    a_w = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 8 and parts[1] in ("passive", "skyhook"):  # the episode table
            a_w[parts[0], parts[1]] = float(parts[3])
    assert len(a_w) == 4
    for backend in ("surrogate", "reference"):
        assert 0 < a_w[backend, "skyhook"] < a_w[backend, "passive"]
    pytest.importorskip("matplotlib")
    assert {p.name for p in (tmp_path / "d").iterdir()} == {
        "samples_and_oob.png",
        "carbody_acceleration.png",
    }


def test_demo_runs_twice_as_written_and_keeps_foreign_folders(tmp_path, monkeypatch, capsys):
    """README command 1 (``railgym demo``, default folder) run a second time replaces its own
    plots; a folder holding another file is still refused (exit 2) and left alone."""
    from agents.commands import cli
    from railgym.envs.vertical.env import VerticalSuspensionEnv
    from railgym.vehicles.collect import build_vertical_surrogate

    monkeypatch.setattr(
        cli,
        "build_vertical_surrogate",
        lambda m, **kw: build_vertical_surrogate(m=41, sampling="greedy", **kw),
    )
    # 4 s episodes: the folder logic is under test here, not the physics
    monkeypatch.setattr(cli, "VerticalSuspensionEnv", partial(VerticalSuspensionEnv, duration=4.0))
    monkeypatch.chdir(tmp_path)
    assert cli.main(["demo"]) == 0
    first = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "railgym-demo").iterdir()}
    assert cli.main(["demo"]) == 0
    again = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "railgym-demo").iterdir()}
    assert set(first) == set(again) == set(cli.DEMO_FILES)
    assert all(again[name] > first[name] for name in first)  # replaced, not kept
    (tmp_path / "railgym-demo" / "notes.txt").write_text("mine")
    capsys.readouterr()
    assert cli.main(["demo"]) == 2
    err = capsys.readouterr().err
    assert "holds 'notes.txt'" in err and "--overwrite" in err
    assert (tmp_path / "railgym-demo" / "notes.txt").read_text() == "mine"


def test_demo_help_lists_the_files_it_writes(capsys):
    from agents.commands import cli

    with pytest.raises(SystemExit):
        cli.main(["demo", "--help"])
    out = capsys.readouterr().out
    assert all(name in out for name in cli.DEMO_FILES) and "run again" in out


def test_build_degree_options_fix_or_widen_the_search(tmp_path, capsys):
    _write_csv(tmp_path / "d.csv")
    assert main(_build_args(tmp_path, "--degree", "3", "2")) == 0
    out = capsys.readouterr().out
    assert io.load(tmp_path / "m.json").degree == (3, 2)
    assert "warning" not in out  # one fixed degree: no search range to widen
    # the candidate table is printed without --quiet
    assert main([a for a in _build_args(tmp_path, "--max-degree", "2") if a != "--quiet"]) == 0
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.strip()[:3] in {"1,1", "1,2", "2,1", "2,2"}]
    assert len(rows) == 4  # the candidates (1..2) × (1..2)
    # the cubic force needs degree 3 in du: the winner sits at the cap, and the warning says
    # which option widens the range
    assert "widen the search range (--max-degree on the command line" in out
    assert main(_build_args(tmp_path, "--max-degree", "5", "1")) == 0
    degree = io.load(tmp_path / "m.json").degree
    assert degree[0] >= 3 and degree[1] == 1  # the search reached the cubic in du


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--degree", "1", "2", "3"], "--degree takes 1 or 2 values"),
        (["--max-degree", "0"], "--max-degree values must be in 1..200"),
        (["--degree", "2", "--kind", "kriging"], "apply to --kind lpr only"),
    ],
)
def test_build_degree_options_bad_values(tmp_path, capsys, extra, message):
    _write_csv(tmp_path / "d.csv")
    assert main(_build_args(tmp_path, *extra)) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "m.json").exists()


def test_collect_command_takes_the_degree_options(tmp_path, capsys):
    from agents.commands import collect
    from railgym.vehicles.memory_element import MEMORY_DEGREES, memory_degrees

    out = tmp_path / "static.json"
    argv = ["--features", "static", "--m", "51", "--out", str(out), "--quiet"]
    assert collect.main([*argv, "--degree", "3", "4"]) == 0
    assert io.load(out).degree == (3, 4)
    assert collect.main([*argv, "--max-degree", "2", "--overwrite"]) == 0
    assert "--max-degree on the command line" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        collect.main(["--features", "maxwell", "--max-degree", "10", "14", "20"])
    assert exc.value.code == 2
    assert "max_degree[0] must be at least 12" in capsys.readouterr().err
    assert memory_degrees((14, 12, 14)) == [(12, 12, 14), (14, 12, 14)]
    assert memory_degrees((16, 16, 20)) == list(MEMORY_DEGREES)


def test_progress_bars_only_on_a_terminal_and_not_when_quiet(monkeypatch):
    import io as stdio
    import sys

    from railgym.progress import quiet, stages
    from surrogates.cli import _progress_bar

    class Terminal(stdio.StringIO):
        def isatty(self):
            return True

    for make in (stages, _progress_bar):
        for stream, silent, shown in (
            (stdio.StringIO(), False, False),
            (Terminal(), False, True),
            (Terminal(), True, make is _progress_bar),  # quiet() is railgym's switch
        ):
            monkeypatch.setattr(sys, "stderr", stream)
            with quiet(silent):
                update = make()
                update("selection", 1, 2)
                update("selection", 2, 2)
            assert ("selection" in stream.getvalue()) == shown, (make, silent)
