"""``railgym leaderboard``: the task list, the table formats, entries with provenance, a
classical controller added as a policy scoring as its baseline row, and bad input."""

from __future__ import annotations

import csv
import io
import json

import pytest

from agents.commands.cli import main
from agents.leaderboard.results import load_entries, table_rows
from railgym.tasks import TASKS


def test_list_names_every_task(capsys):
    assert main(["leaderboard", "--list"]) == 0
    out = capsys.readouterr().out
    assert [line.split(":")[0] for line in out.splitlines()] == list(TASKS)


def test_controller_as_policy_scores_as_its_baseline_row(tmp_path, capsys):
    assert (
        main(
            [
                "leaderboard",
                "run",
                "--task",
                "crash-adaptive",
                "--policy",
                "speed-adaptive",
                "--name",
                "mine",
                "--results",
                str(tmp_path),
            ]
        )
        == 0
    )
    mine = load_entries(tmp_path, ["crash-adaptive"])[0]
    shipped = [e for e in load_entries(tasks=["crash-adaptive"]) if e["name"] == "speed-adaptive"]
    (row,) = table_rows([mine])
    (base,) = table_rows(shipped)
    assert (row["iqm"], row["ci_low"], row["ci_high"]) == (
        base["iqm"],
        base["ci_low"],
        base["ci_high"],
    )
    prov = mine["provenance"]
    assert {"railgym", "commit", "config_hash", "machine", "wall_s"} <= set(prov)
    assert mine["kind"] == "policy" and mine["seeds"] == [0]


def test_run_without_results_writes_the_default_folder(tmp_path, monkeypatch, capsys):
    """No ``--results``: the entry goes to the default folder (the shipped results)."""
    import agents.commands.leaderboard as command

    monkeypatch.setattr(command, "RESULTS_DIR", tmp_path)
    argv = ["leaderboard", "run", "--task", "crash-adaptive", "--policy", "passive"]
    assert main([*argv, "--name", "default-folder"]) == 0
    (entry,) = load_entries(tmp_path, ["crash-adaptive"])
    assert entry["name"] == "default-folder" and entry["kind"] == "policy"


@pytest.mark.parametrize("fmt", ["md", "csv", "json"])
def test_table_formats(fmt, capsys):
    assert main(["leaderboard", "--task", "crash-adaptive", "--format", fmt]) == 0
    out = capsys.readouterr().out
    names = {e["name"] for e in load_entries(tasks=["crash-adaptive"])}
    if fmt == "json":
        assert {r["entry"] for r in json.loads(out)} == names
    elif fmt == "csv":
        assert {r["entry"] for r in csv.DictReader(io.StringIO(out))} == names
    else:
        assert out.startswith("| task | entry |") and all(f"| {n} |" in out for n in names)


def test_passive_row_scores_zero(capsys):
    rows = table_rows(load_entries(tasks=["bogie-active"]))
    passive = next(r for r in rows if r["entry"] == "passive")
    assert (passive["iqm"], passive["ci_low"], passive["ci_high"]) == (0.0, 0.0, 0.0)


def test_bad_input_is_one_line_and_status_2(tmp_path, capsys):
    assert (
        main(
            [
                "leaderboard",
                "run",
                "--task",
                "crash-adaptive",
                "--policy",
                "nothing",
                "--results",
                str(tmp_path),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert err.startswith("railgym leaderboard run: error:") and "\n" not in err
    with pytest.raises(SystemExit) as exc:
        main(["leaderboard", "--task", "no-task"])
    assert exc.value.code == 2
    assert main(["leaderboard", "--quick"]) == 2
