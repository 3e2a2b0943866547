"""The validity flags where the agents report them: ``railgym evaluate``'s tables and the
measurement of :mod:`agents.evaluation.validity` (errors against the reference beside the flags)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from agents.commands.validity import main
from agents.evaluation.evaluate import format_rows, format_vehicle_rows
from agents.evaluation.runs import run_policy, run_vehicle_policy
from agents.evaluation.validity import case_episodes, target_holds
from agents.evaluation.validity import format_rows as validity_table


def _passive(env):
    from agents.controllers.classical import Passive

    return Passive(env)


@pytest.mark.parametrize("backend", ["surrogate", "reference"])
def test_the_vertical_rows_carry_the_flags_and_the_table_shows_them_for_the_surrogate(backend):
    kwargs = {"backend": backend, "track_class": 3, "speed": 40.0, "duration": 3.0}
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        row = run_policy(_passive, kwargs, 2, 1000)
    warned = any("outside that envelope" in str(w.message) for w in seen)
    assert warned is (backend == "surrogate")  # class 3 at 1.5 × its maximum speed
    assert row["backend"] == backend and row["outside_envelope"] is warned
    assert 0.0 <= row["outside_element_%"] <= 100.0
    full = {"track_class": 3, "policy": "passive", "a_w_reduction_%": 0.0, **row}
    head, line = format_rows([full]).splitlines()
    if backend == "surrogate":
        assert head.endswith("out-box % envelope") and line.split()[-1] == "outside"
        assert float(line.split()[-2]) == pytest.approx(row["outside_element_%"], rel=1e-2)
    else:
        assert "out-box" not in head and "envelope" not in head


def test_the_vehicle_table_marks_other_backends_rows_with_a_dash():
    kwargs = {"track_class": 5, "duration": 0.5}
    rows = []
    for backend in ("surrogate", "reference"):
        ix = run_vehicle_policy(_passive, {"backend": backend, **kwargs}, 1, 1000)
        rows.append({"track_class": 5, "policy": "passive", "a_w_reduction_%": np.zeros(3), **ix})
    assert [r["outside_envelope"] for r in rows] == [False, False]
    lines = format_vehicle_rows(rows).splitlines()
    assert lines[0].endswith("out-box % envelope")
    assert lines[1].split()[-1] == "inside" and lines[2].split()[-2:] == ["-", "-"]


def test_a_short_case_has_consistent_flags():
    r = case_episodes("vertical", 4, 2.0, n_seeds=2, duration=2.0)
    assert r["error"].shape == r["outside_element_%"].shape == r["flagged"].shape == (2,)
    assert r["outside_envelope"].all() and r["flagged"].all()
    np.testing.assert_array_equal(r["error"], r["error_points"].max(axis=1))


def _row(errors, flagged):
    n = len(errors)
    return {
        "env": "vertical",
        "controller": "passive",
        "class": 4,
        "factor": 1.0,
        "speed_kmh": 128.0,
        "error": np.array(errors),
        "outside_element_%": np.zeros(n),
        "outside_envelope": np.array(flagged),
        "flagged": np.array(flagged),
    }


def test_the_target_counts_unflagged_episodes_above_the_threshold():
    assert target_holds([_row([3.0, 9.0], [False, True])])
    assert not target_holds([_row([3.0, 9.0], [True, False])])
    text = validity_table([_row([3.0, 9.0], [True, False])])
    assert "(miss)" in text and text.endswith("the target does not hold.")


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        ("--env vertical --controller modal-skyhook", "not a controller of --env vertical"),
        ("--factor 2.5", "--factor"),
        ("--factor 0", "--factor"),
        ("--track-class 7", "--track-class"),
        ("--seeds 0", "--seeds"),
        ("--duration 0", "--duration"),
    ],
)
def test_the_command_names_a_bad_flag(capsys, argv, flag):
    with pytest.raises(SystemExit) as exc:
        main(argv.split())
    assert exc.value.code == 2 and flag in capsys.readouterr().err


@pytest.mark.parametrize(
    ("env", "track_class", "factor", "inside"),
    [
        ("vertical", 4, 2.0, False),  # out of the box on many steps: 10-22 %
        ("vehicle", 3, 1.5, False),  # inside the box, outside the envelope: up to 18 %
        ("vehicle", 5, 1.0, True),  # the validated case: about 2 %
    ],
)
def test_every_episode_above_8_percent_is_flagged(env, track_class, factor, inside):
    """docs/validation.md, *Validity flags*: 5 unseen tracks of 20 s, passive."""
    r = case_episodes(env, track_class, factor)
    assert target_holds([r])
    assert bool(r["outside_envelope"].any()) is not inside
    if inside:
        assert r["error"].max() < 8.0
    else:
        assert r["error"].max() > 8.0
