"""The user's train through the crash commands: ``railgym evaluate --env crash --scenario``,
``--envelope``, ``railgym crash-report`` and ``crash-limits`` run the file's cars and speed (or
its envelope), say so over the table, and refuse what they cannot honour, naming it."""

from __future__ import annotations

import pytest

from agents.commands.cli import main
from tests.envs.crash.user_train import write_train

TRAIN = "scenario my_train (3 cars, 42 / 38 / 38 t, speed_kmh 36)"


def _rows(out: str) -> list[dict[str, str]]:
    """The data lines of a ``railgym evaluate --env crash`` table: the speed, the policy and
    the per-car peaks and per-zone crush cells (cut at the header's column starts)."""
    lines = out.splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.lstrip().startswith("km/h"))
    head = lines[at]
    cols = [head.index(c) for c in ("policy", "peak decel", "Δpeak", "max crush", "stroke")]
    rows = []
    for ln in lines[at + 1 :]:
        if ln.strip():
            cells = [ln[: cols[0]], *(ln[a:b] for a, b in zip(cols, cols[1:], strict=False))]
            keys = ("km/h", "policy", "peak", "reduction", "crush")
            rows.append(dict(zip(keys, (c.strip() for c in cells), strict=True)))
    return rows


def test_evaluate_runs_the_files_cars_at_its_speed(tmp_path, capsys):
    path = write_train(tmp_path)
    assert main(["evaluate", "passive", "--env", "crash", "--scenario", str(path)]) == 0
    out = capsys.readouterr().out
    head = out.splitlines()[0]
    assert TRAIN in head and "impact speed: the scenario's speed_kmh" in head
    (row,) = _rows(out)
    assert row["km/h"] == "36" and row["policy"] == "passive"
    assert len(row["peak"].split()) == 3 and len(row["crush"].split()) == 3  # per car, zone
    # a flag that overrides the file's speed says so over the table
    args = ["evaluate", "passive", "--env", "crash", "--scenario", str(path), "--speed-kmh", "30"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "impact speeds from --speed-kmh (override the scenario's speed_kmh)" in out
    assert [r["km/h"] for r in _rows(out)] == ["30"]


def test_packaged_scenario_speed_and_cars(capsys):
    assert main(["evaluate", "passive", "--env", "crash", "--scenario", "trainset"]) == 0
    out = capsys.readouterr().out
    assert "scenario trainset (4 cars" in out
    (row,) = _rows(out)
    assert row["km/h"] == "25" and len(row["peak"].split()) == 4


def test_envelope_reads_the_file(tmp_path, capsys):
    bare = write_train(tmp_path)
    args = ["evaluate", "passive", "--env", "crash", "--envelope", "--scenario"]
    assert main([*args, str(bare)]) == 2
    err = capsys.readouterr().err
    assert "scenario 'my_train' has no impact envelope (its crash.envelope" in err
    stopped = write_train(tmp_path, name="stopped", speed_kmh=0)
    assert main([*args, str(stopped)]) == 2
    assert "crash.speed_kmh" in capsys.readouterr().err
    envelope = {"speed_kmh": [30.0, 40.0], "payload_t": {"lead": 1.0, "passenger": [0.0, 4.0]}}
    wide = write_train(tmp_path, name="wide", envelope=envelope)
    assert main([*args, str(wide)]) == 0
    out = capsys.readouterr().out
    assert "scenario wide (3 cars, 42 / 38 / 38 t, speed_kmh 36)" in out.splitlines()[0]
    cases = {tuple(c.strip() for c in ln.split("|")[1:3]) for ln in out.splitlines()}
    speeds = ("30", "32", "34", "36", "38", "40")
    assert {(v, p) for v in speeds for p in ("1 / 0", "1 / 4")} <= cases
    peaks = [ln.split("|")[4] for ln in out.splitlines() if ln.startswith("| 30 | 1 / 0 |")]
    assert peaks and all(len(p.split("/")) == 3 for p in peaks)  # a peak per car


def test_crash_report_refuses_matrix_with_envelope(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["crash-report", "--matrix", "--envelope"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "--matrix, --envelope" in err.splitlines()[-1]


def test_crash_report_and_limits_read_the_scenario(tmp_path, capsys):
    bare = write_train(tmp_path)
    assert main(["crash-report", "--envelope", "--scenario", str(bare)]) == 2
    assert "has no impact envelope (its crash.envelope" in capsys.readouterr().err
    assert main(["crash-limits", "--scenario", str(bare), "--levels", "2"]) == 2
    assert "has no impact envelope (its crash.envelope" in capsys.readouterr().err
    envelope = {"speed_kmh": 36.0}
    fixed = write_train(tmp_path, name="fixed", envelope=envelope)
    assert main(["crash-report", "--envelope", "--scenario", str(fixed)]) == 0
    out = capsys.readouterr().out
    assert "scenario fixed (3 cars" in out.splitlines()[0]
    assert sum(ln.startswith("| 36 | 0 / 0 |") for ln in out.splitlines()) == 3
