"""``railgym semi-active-bound`` (:mod:`agents.commands.semi_active_bound`): through the
``railgym`` entry point, its table is :func:`~agents.evaluation.semi_active_bound.optimise_track`'s
on the newest version by default, and a bad flag is one error naming it before any work."""

from __future__ import annotations

import subprocess
import sys

import pytest

from agents.commands.cli import main
from agents.evaluation.semi_active_bound import format_results, optimise_track
from railgym.registration import newest

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def test_help_exits_0_in_a_fresh_process():
    proc = subprocess.run(
        [sys.executable, "-m", "agents.commands.cli", "semi-active-bound", "--help"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0 and proc.stderr == ""
    assert proc.stdout.startswith("usage: railgym semi-active-bound")
    assert "--screen-eval" in proc.stdout and "(default: 1000)" in proc.stdout


def test_the_command_prints_the_search_of_each_track_on_the_newest_version(capsys):
    """One short track: the table row and the header are those of ``optimise_track`` on
    the newest ``VerticalSuspension`` (the default), the seed of ``--seed``."""
    argv = ["--track-class", "5", "--seed", "1001", "--seeds", "1", "--duration", "2.5"]
    argv += ["--screen-eval", "1", "--max-eval", "2", "--quiet"]
    assert main(["semi-active-bound", *argv]) == 0
    out, err = capsys.readouterr()
    env_id = newest("railgym/VerticalSuspension")
    assert out.startswith(f"{env_id}, reference backend, actuator semi-active, 2.5 s per track")
    assert err == ""
    direct = optimise_track(5, 1001, 2.5, screen_eval=1, max_eval=2, env_id=env_id)
    assert _row(out) == _row(format_results([direct]))


def _row(table: str) -> list[str]:
    """The a_w of passive, clipped-lqg, skyhook, best and the margin of class 5, seed 1001."""
    return next(x for x in table.splitlines() if x.startswith("| 5 | 1001 |")).split("|")[3:8]


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--duration", "1.5"], ["--duration", "settling time"]),
        (["--duration", "nan"], ["--duration"]),
        (["--duration", "0"], ["--duration", "0 < x"]),
        (["--screen-eval", "0"], ["--screen-eval", "1..10000"]),
        (["--max-eval", "-2"], ["--max-eval"]),
        (["--seeds", "0"], ["--seeds"]),
        (["--seed", "4294967295", "--seeds", "2"], ["--seed", "4294967295"]),
        (["--track-class", "7"], ["--track-class"]),
        (["--env-id", "railgym/VerticalVehicle-v3"], ["--env-id", "invalid choice"]),
        (["--seeds", "1000", "1001"], ["unrecognized arguments: 1001"]),
    ],
)
def test_bad_flags_name_the_flag(args: list[str], words: list[str], capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["semi-active-bound", *args])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err
