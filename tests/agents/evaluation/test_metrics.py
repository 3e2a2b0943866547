"""The one table of metrics (agents.evaluation.metrics): the keys run_policy returns and the
names and units the tables print."""

from __future__ import annotations

import numpy as np

from agents.controllers.classical import Passive
from agents.evaluation.evaluate import format_rows, format_vehicle_rows
from agents.evaluation.gap import format_gap, gap_vertical
from agents.evaluation.metrics import VEHICLE, VERTICAL, metrics
from agents.evaluation.runs import run_policy, run_vehicle_policy

#: keys of an evaluation row that no run returns (computed against the passive row)
AGAINST_PASSIVE = {"a_w_reduction_%"}


def test_run_policy_returns_the_declared_metrics_and_the_old_key():
    row = run_policy(Passive, {"backend": "linear", "duration": 3.0}, 2, 0)
    keys = {m.key for m in VERTICAL} - AGAINST_PASSIVE
    assert keys <= set(row)
    (wz,) = metrics(VERTICAL, "Wz")
    assert row["wz"] == row["Wz"] == wz.value({"wz": row["wz"]}) > 0  # old key kept


def test_run_vehicle_policy_returns_the_declared_metrics():
    row = run_vehicle_policy(Passive, {"backend": "linear", "duration": 3.0}, 1, 0)
    assert {m.key for m in VEHICLE} - AGAINST_PASSIVE <= set(row)
    assert row["a_w"].shape == row["Wz"].shape == (3,)


def test_format_rows_prints_each_metric_by_name_and_unit():
    row = {"track_class": 4, "policy": "passive", "a_w_reduction_%": 0.0}
    row |= {"rms_acc": 0.5, "a_w": 0.25, "wz": 2.5, "max_defl_mm": 12.0, "contacts": 3}
    head, line = format_rows([row]).splitlines()
    titles = [m.title for m in VERTICAL]
    assert titles == ["RMS ẍ2 m/s²", "a_w Wk m/s²", "Δa_w %", "Wz", "max |δ| mm", "contacts"]
    assert [head.index(t) for t in titles] == sorted(head.index(t) for t in titles)
    cells = line.split()[2:]
    expected = ["0.500", "0.250", "0.0", "2.50", "12.0", "3"]
    assert cells == [m.cell(row) for m in VERTICAL] == expected


def test_format_vehicle_rows_prints_each_metric_by_name_and_unit():
    three = np.array([0.1, 0.2, 0.3])
    row = {"track_class": 5, "policy": "passive", "speed_kmh": 100.0, "contacts": 0, "ood": 0}
    row |= dict.fromkeys(("rms_acc", "a_w", "a_w_reduction_%", "a_ZP95_Wb", "Wz"), three)
    head, line = format_vehicle_rows([row]).splitlines()
    for m in VEHICLE:
        assert m.title in head and m.cell(row) in line
    assert "a_ZP95 Wb m/s²" in head and "0.100/0.200/0.300" in line


def test_gap_and_benchmark_name_the_metric_by_key_and_unit():
    (a_w,) = metrics(VERTICAL, "a_w")
    assert a_w.label() == "a_w (m/s²)" and a_w.label("front") == "a_w front (m/s²)"
    rows = gap_vertical(["passive"], (6,), 1, backends=("linear", "linear"))
    assert [r["metric"] for r in rows] == ["a_w (m/s²)"] and rows[0]["gap"] == 0.0
    assert "a_w (m/s²)" in format_gap(rows)
