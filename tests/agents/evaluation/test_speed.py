"""The speed table of ``railgym demo`` (:mod:`agents.evaluation.speed`): what it measured, positive
rates, the ratio column, every figure taken from the clock (a fake clock proves the table prints
what it timed), and the FMU row skipped with a note where it cannot be built. No figure is
compared with a speed target (speed belongs in ``benchmarks/``)."""

from __future__ import annotations

import re
import sys
from types import SimpleNamespace

import pytest

from agents.evaluation import speed
from agents.evaluation.speed import SpeedRow, backend_speeds, format_speeds
from railgym.envs.vertical.env import VerticalSuspensionEnv, VerticalSuspensionVectorEnv
from railgym.vehicles.collect import default_vertical_surrogate
from tests.fresh_process import run_cli

#: a table row: mode, label, sub-envs, steps, env-steps/s, × reference
ROW = re.compile(
    r"^(vector|single)\s+(surrogate \(numba\)|reference \(numba\)|reference FMU \(FMPy\))\s+"
    r"(\d+)\s+(\d+)\s+(\S+)\s+(\S+)$"
)


#: a row of the comparisons the table leads with: what is compared, env id, surrogate ×
LEAD = re.compile(r"^(surrogate vs [^,]+, (?:vector envs|single env))\s+(railgym/\S+)\s+(\S+)$")
#: the line that takes the FMU comparison's place where it cannot be measured
HOW_TO = "surrogate vs reference FMU in the loop: not measured: "


def _lead(out: str) -> list[str]:
    """The header of the comparisons and the lines after it, up to the detailed table."""
    lines = out.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("comparison (env-steps/s)"))
    end = next(i for i in range(start, len(lines)) if lines[i].startswith("measured now"))
    return lines[start:end]


def _table(out: str) -> dict[tuple[str, str], tuple[int, int, float, float]]:
    rows = {}
    for line in out.splitlines():
        m = ROW.match(line.strip())
        if m:
            mode, label, n_envs, n_steps, rate, ratio = m.groups()
            rows[mode, label] = (int(n_envs), int(n_steps), float(rate), float(ratio))
    return rows


def test_demo_in_a_fresh_process_prints_the_speed_table(tmp_path):
    proc = run_cli("demo", "--out", str(tmp_path / "d"), "--quiet", cwd=tmp_path)
    out = proc.stdout
    assert proc.returncode == 0, proc.stderr
    assert "5. speed: the surrogate element against the high-fidelity model it replaces" in out
    lead = _lead(out)
    assert re.match(r"comparison \(env-steps/s\) +env id +surrogate ×$", lead[0])
    if speed.fmu_unavailable() is None:  # the first row: the surrogate against the FMU
        first = LEAD.match(lead[1])
        assert first is not None, lead[1]
        assert first.groups()[:2] == (
            "surrogate vs reference FMU in the loop, vector envs",
            "railgym/VerticalSuspension-v3",
        )
        assert float(first.group(3)) > 1.0  # the FMU in the loop is the slow one
    else:
        assert lead[1].startswith(HOW_TO)
    internal = [LEAD.match(line) for line in lead[2:]]
    assert [(m.group(1), m.group(2)) for m in internal if m] == [
        ("surrogate vs internal reference, single env", "railgym/VerticalSuspension-v3"),
        ("surrogate vs internal reference, vector envs", "railgym/VerticalSuspension-v3"),
    ]
    # says what it measured: sub-envs (a column), steps, rounds, threads, compilation
    assert re.search(r"200 steps per round .*median of 3 interleaved rounds, 1 numba thread", out)
    assert "500 of the single envs" in out
    assert "kernels compiled before timing" in out
    assert re.search(r"mode +model +sub-envs +steps +env-steps/s +× reference", out)
    rows = _table(out)
    numba_rows = {
        (m, f"{b} (numba)") for m in ("vector", "single") for b in ("surrogate", "reference")
    }
    assert set(rows) >= numba_rows
    for n_envs, n_steps, rate, ratio in rows.values():
        assert n_envs > 0 and n_steps > 0 and rate > 0 and ratio > 0
    vec, one = ("vector", "surrogate (numba)"), ("single", "surrogate (numba)")
    assert rows[vec][:2] == rows["vector", "reference (numba)"][:2] == (256, 200)
    assert rows[one][:2] == rows["single", "reference (numba)"][:2] == (1, 500)
    assert rows["vector", "reference (numba)"][3] == rows["single", "reference (numba)"][3] == 1.0
    if ("vector", "reference FMU (FMPy)") in rows:
        assert rows["vector", "reference FMU (FMPy)"][:2] == (speed.FMU_ENVS, 20)
    # the existing outputs stay: the episode table with its wall-time column, the plots line
    assert re.search(r"surrogate +passive +\S+ +\S+ +\S+ +\d+ +\d+ +\S+", out)
    assert f"plots written to {tmp_path / 'd'}/" in out


def test_speed_table_skips_the_fmu_row_without_fmpy_or_compiler(monkeypatch):
    from surrogates.fmi import export

    model = default_vertical_surrogate("static")
    monkeypatch.setitem(sys.modules, "fmpy", None)  # import fmpy raises ImportError
    rows, skipped = backend_speeds(model, n_envs=8, n_steps=3, rounds=1, single_steps=3)
    assert [(r.mode, r.model) for r in rows] == [
        ("vector", "surrogate"),
        ("vector", "reference"),
        ("single", "surrogate"),
        ("single", "reference"),
    ]
    assert skipped is not None and "pip install 'railgym[fmi]'" in skipped
    text = format_speeds(rows, skipped, 1)
    lead = _lead(text)
    assert lead[1] == HOW_TO + skipped  # the first row: how to get the FMU comparison
    assert [LEAD.match(line).group(1) for line in lead[2:]] == [
        "surrogate vs internal reference, single env",
        "surrogate vs internal reference, vector envs",
    ]
    assert "reference FMU (FMPy)" not in text
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
        ("vector", "surrogate (numba)"): (256, 200, 1.2e6, 3.0),
        ("vector", "reference (numba)"): (256, 200, 4.0e5, 1.0),
        ("vector", "reference FMU (FMPy)"): (16, 20, 5.0e3, 0.0125),
    }
    assert "200 steps per round of the vector envs (20 of the FMU), median of 3 interleaved" in text
    assert _lead(text)[1:] == [
        f"{'surrogate vs reference FMU in the loop, vector envs':<52} {speed.ENV_ID:<30} {240:11d}",
        f"{'surrogate vs internal reference, vector envs':<52} {speed.ENV_ID:<30} {3:11d}",
    ]
    single = [SpeedRow("surrogate", 1, 500, 6e4, 1.5, 1.0, "single")]
    single.append(SpeedRow("reference", 1, 500, 4e4, 1.0, 1.5, "single"))
    text = format_speeds(rows + single, None, 3)
    assert _table(text)["single", "surrogate (numba)"] == (1, 500, 6e4, 1.5)
    assert ", 500 of the single envs, median of 3" in text
    lead = [LEAD.match(line).groups() for line in _lead(text)[1:]]
    assert [(what, float(ratio)) for what, _, ratio in lead] == [
        ("surrogate vs reference FMU in the loop, vector envs", 240.0),
        ("surrogate vs internal reference, single env", 1.5),
        ("surrogate vs internal reference, vector envs", 3.0),
    ]


#: seconds per env-step in each round on the fake clock, by (mode, backend)
COSTS = {
    ("vector", "surrogate"): (1e-6, 3e-6, 2e-6),
    ("vector", "reference"): (5e-6, 6e-6, 10e-6),
    ("vector", "fmu"): (400e-6, 500e-6, 800e-6),
    ("single", "surrogate"): (20e-6, 20e-6, 40e-6),
    ("single", "reference"): (25e-6, 30e-6, 30e-6),
}


@pytest.mark.parametrize("with_fmu", [False, True], ids=["no FMU", "FMU"])
def test_speed_table_prints_what_the_clock_measured(monkeypatch, with_fmu):
    """On a clock that moves only in env steps, by :data:`COSTS` a step in each round (the
    first step, before the timing, is round -1 and free): the rates are the medians of the
    per-round rates, each ratio the median of the per-round ratios (5, not 6 / 2 = 3, the
    ratio of the medians), and the printed table shows exactly these figures."""
    if with_fmu and speed.fmu_unavailable() is not None:
        pytest.skip(f"no FMU: {speed.fmu_unavailable()}")
    if not with_fmu:
        monkeypatch.setattr(speed, "fmu_unavailable", lambda: "FMU left out by the test")
    clock, calls = [0.0], {}
    monkeypatch.setattr(speed, "time", SimpleNamespace(perf_counter=lambda: clock[0]))
    n_steps, fmu_steps, single_steps = 4, 2, 3
    blocks = {"vector": n_steps, "fmu": fmu_steps, "single": single_steps}

    def costly(step):
        def timed_step(env, action):
            vector = isinstance(env, VerticalSuspensionVectorEnv)
            mode, backend = "vector" if vector else "single", env.cfg.backend
            k = calls[id(env)] = calls.get(id(env), -1) + 1
            if k > 0:  # step k - 1 of the rounds: round (k - 1) // steps per round
                per_round = blocks["fmu" if backend == "fmu" else mode]
                cost = COSTS[mode, backend][(k - 1) // per_round]
                clock[0] += cost * (env.num_envs if vector else 1)
            return step(env, action)

        return timed_step

    for cls in (VerticalSuspensionVectorEnv, VerticalSuspensionEnv):
        monkeypatch.setattr(cls, "step", costly(cls.step))
    model = default_vertical_surrogate("static")
    rows, skipped = backend_speeds(
        model, n_envs=8, n_steps=n_steps, rounds=3, fmu_steps=fmu_steps, single_steps=single_steps
    )
    by = {(r.mode, r.model): r for r in rows}
    assert (skipped is None) == with_fmu and (("vector", "reference FMU") in by) == with_fmu
    want = {  # (env-steps/s, × reference, surrogate × it)
        ("vector", "surrogate"): (5e5, 5.0, 1.0),
        ("vector", "reference"): (1e6 / 6, 1.0, 5.0),
        ("vector", "reference FMU"): (2000.0, 0.0125, 400.0),
        ("single", "surrogate"): (5e4, 1.25, 1.0),
        ("single", "reference"): (1e6 / 30, 1.0, 1.25),
    }
    if not with_fmu:
        del want["vector", "reference FMU"]
    assert set(by) == set(want)
    for key, (rate, vs_ref, sur_over) in want.items():
        r = by[key]
        assert r.steps_per_s == pytest.approx(rate, rel=1e-9), key
        assert r.vs_reference == pytest.approx(vs_ref, rel=1e-9), key
        assert r.surrogate_over == pytest.approx(sur_over, rel=1e-9), key
    assert by["vector", "surrogate"].n_envs == 8 and by["single", "surrogate"].n_envs == 1
    text = format_speeds(rows, skipped, 3)
    table = _table(text)
    for (mode, model_name), (rate, vs_ref, _) in want.items():
        n_envs, steps, printed_rate, printed_ratio = table[mode, speed._WHAT[model_name]]
        assert (n_envs, steps) == (by[mode, model_name].n_envs, by[mode, model_name].n_steps)
        assert printed_rate == pytest.approx(rate, rel=1e-3)
        assert printed_ratio == pytest.approx(vs_ref, rel=1e-3)
    # the comparisons it leads with: the surrogate over the other, medians of per-round ratios
    lead = _lead(text)
    first = [("surrogate vs reference FMU in the loop, vector envs", 400.0)] if with_fmu else []
    internal = [m.groups() for m in map(LEAD.match, lead[1:]) if m]
    assert [(what, float(ratio)) for what, _, ratio in internal] == first + [
        ("surrogate vs internal reference, single env", 1.25),
        ("surrogate vs internal reference, vector envs", 5.0),
    ]
    assert {env_id for _, env_id, _ in internal} == {"railgym/VerticalSuspension-v3"}
    if not with_fmu:
        assert lead[1] == HOW_TO + "FMU left out by the test"


def test_single_steps_longer_than_an_episode_are_refused():
    n = VerticalSuspensionEnv().cfg.n_steps
    with pytest.raises(ValueError, match=f"single_steps must be at most an episode's {n} steps"):
        backend_speeds(
            default_vertical_surrogate("static"), n_envs=8, n_steps=1, single_steps=n + 1
        )


def test_demo_without_fmpy_leads_with_how_to_get_it(tmp_path, monkeypatch, capsys):
    """Without FMPy the demo's first comparison is the line saying how to get it, and the
    internal reference rows follow with the ratios of the printed table's rates."""
    from agents.commands import cli
    from railgym.vehicles.collect import build_vertical_surrogate

    def quick_build(m, **kwargs):  # a smaller, faster build of the same element
        return build_vertical_surrogate(m=41, sampling="greedy", **kwargs)

    monkeypatch.setattr(cli, "build_vertical_surrogate", quick_build)
    monkeypatch.setitem(sys.modules, "fmpy", None)  # import fmpy raises ImportError
    assert cli.main(["demo", "--out", str(tmp_path / "d"), "--quiet"]) == 0
    out = capsys.readouterr().out
    lead = _lead(out)
    assert lead[1] == HOW_TO + "FMPy is not installed (pip install 'railgym[fmi]')"
    ratios = {m.group(1): float(m.group(3)) for m in map(LEAD.match, lead[2:]) if m}
    rows = _table(out)
    assert set(rows) == {
        (m, f"{b} (numba)") for m in ("vector", "single") for b in ("surrogate", "reference")
    }
    for mode, what in (("single", "single env"), ("vector", "vector envs")):
        # the lead ratio is the surrogate row's × reference (both medians of per-round ratios)
        lead_ratio = ratios[f"surrogate vs internal reference, {what}"]
        assert lead_ratio == pytest.approx(rows[mode, "surrogate (numba)"][3], rel=2e-3)
