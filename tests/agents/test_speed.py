"""The speed table of ``railgym demo`` (:mod:`agents.speed`): what it measured, positive rates,
the ratio column, and the FMU row skipped with a note where it cannot be built. No figure is
compared with a speed target (speed belongs in ``benchmarks/``)."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from agents import speed
from agents.speed import SpeedRow, backend_speeds, format_speeds
from railgym.vehicles.collect import default_vertical_surrogate

#: a table row: label, sub-envs, steps, env-steps/s, × reference
ROW = re.compile(
    r"^(surrogate \(numba\)|reference \(numba\)|reference FMU \(FMPy\))\s+(\d+)\s+(\d+)\s+"
    r"(\S+)\s+(\S+)$"
)


def _table(out: str) -> dict[str, tuple[int, int, float, float]]:
    rows = {}
    for line in out.splitlines():
        m = ROW.match(line.strip())
        if m:
            label, n_envs, n_steps, rate, ratio = m.groups()
            rows[label] = (int(n_envs), int(n_steps), float(rate), float(ratio))
    return rows


def test_demo_in_a_fresh_process_prints_the_speed_table(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "agents.cli", "demo", "--out", str(tmp_path / "d"), "--quiet"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=600,
        check=False,
    )
    out = proc.stdout
    assert proc.returncode == 0, proc.stderr
    assert "5. speed: the surrogate element against the reference model it replaces" in out
    # says what it measured: sub-envs (a column), steps, rounds, threads, compilation
    assert re.search(r"200 steps per round .*median of 3 interleaved rounds, 1 numba thread", out)
    assert "kernels compiled before timing" in out
    assert re.search(r"sub-envs +steps +env-steps/s +× reference", out)
    rows = _table(out)
    assert set(rows) >= {"surrogate (numba)", "reference (numba)"}
    for n_envs, n_steps, rate, ratio in rows.values():
        assert n_envs > 0 and n_steps > 0 and rate > 0 and ratio > 0
    assert rows["surrogate (numba)"][:2] == rows["reference (numba)"][:2] == (256, 200)
    assert rows["reference (numba)"][3] == 1.0
    if "reference FMU (FMPy)" in rows:
        assert rows["reference FMU (FMPy)"][:2] == (speed.FMU_ENVS, 20)
        assert re.search(r"× as fast as the reference FMU in the loop", out)
    else:
        assert "reference FMU: not measured: " in out
    assert re.search(r"the surrogate steps \S+ × as fast as the reference", out)
    # the existing outputs stay: the episode table with its wall-time column, the plots line
    assert re.search(r"surrogate +passive +\S+ +\S+ +\S+ +\d+ +\d+ +\S+", out)
    assert f"plots written to {tmp_path / 'd'}/" in out


def test_speed_table_skips_the_fmu_row_without_fmpy_or_compiler(monkeypatch):
    from surrogates.fmi import export

    model = default_vertical_surrogate("static")
    monkeypatch.setitem(sys.modules, "fmpy", None)  # import fmpy raises ImportError
    rows, skipped = backend_speeds(model, n_envs=8, n_steps=3, rounds=1)
    assert [r.model for r in rows] == ["surrogate", "reference"]
    assert skipped is not None and "pip install 'railgym[fmi]'" in skipped
    text = format_speeds(rows, skipped, 1)
    assert f"reference FMU: not measured: {skipped}" in text
    assert "FMU in the loop" not in text
    monkeypatch.undo()
    pytest.importorskip("fmpy")

    def no_compiler(compiler=None):
        raise export.FMUExportError("no C compiler found")

    monkeypatch.setattr(export, "find_compiler", no_compiler)
    assert "no C compiler" in speed.fmu_unavailable()


def test_format_speeds_prints_the_rows_and_their_ratios():
    rows = [
        SpeedRow("surrogate", 256, 200, 1.2e6, 3.0, 1.0),
        SpeedRow("reference", 256, 200, 4.0e5, 1.0, 3.0),
        SpeedRow("reference FMU", 16, 20, 5.0e3, 0.0125, 240.0),
    ]
    text = format_speeds(rows, None, 3)
    table = _table(text)
    assert table == {
        "surrogate (numba)": (256, 200, 1.2e6, 3.0),
        "reference (numba)": (256, 200, 4.0e5, 1.0),
        "reference FMU (FMPy)": (16, 20, 5.0e3, 0.0125),
    }
    assert "200 steps per round (20 of the FMU), median of 3 interleaved rounds" in text
    assert text.splitlines()[-1] == (
        "the surrogate steps 3 × as fast as the reference and 240 × as fast as the reference "
        "FMU in the loop (this machine, this run)"
    )
