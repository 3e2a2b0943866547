"""The metrics of the evaluations, declared once: key, name, unit and description of each.

* :data:`VERTICAL` — the row of :func:`agents.evaluation.runs.run_policy` (and of
  :func:`agents.evaluation.sweeps.evaluate_sweep`, with ``a_w_reduction_%``), in the column
  order of :func:`agents.evaluation.evaluate.format_rows`;
* :data:`VEHICLE` — the row of :func:`agents.evaluation.runs.run_vehicle_policy` (per floor
  point: front, centre, rear), in the column order of ``format_vehicle_rows``;
* :data:`CRASH` — the crash criteria per car or zone (the gap rows of ``--env crash``);
  :data:`ENVELOPE` — the crash envelope summary
  (:func:`agents.evaluation.crash_report.envelope_summary`).

``railgym benchmark`` writes a metric's ``key`` and ``unit`` (``results.csv``), ``railgym
evaluate --gap`` its :meth:`Metric.label`, the text tables its :attr:`Metric.title`. A row
holds a metric under its ``key``; an old key (``aliases``: the vertical ``wz``) is still
written and read.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

__all__ = ["CRASH", "ENVELOPE", "VEHICLE", "VERTICAL", "Metric", "metrics"]


class Metric(NamedTuple):
    """One metric: its row ``key``, printed ``name``, ``unit`` (``""``: none) and
    ``description``; ``fmt`` and ``width`` (least) of its text-table cell; ``unit_in_title``:
    whether the column title shows the unit; ``aliases``: old keys of the same value."""

    key: str
    name: str
    unit: str
    description: str
    fmt: str = ".3f"
    width: int = 0
    unit_in_title: bool = True
    aliases: tuple[str, ...] = ()

    @property
    def title(self) -> str:
        """Column title of the text tables: the name and the unit (``a_w Wk m/s²``)."""
        return f"{self.name} {self.unit}" if self.unit and self.unit_in_title else self.name

    def label(self, where: str = "", by_name: bool = False) -> str:
        """``key where (unit)``, e.g. ``a_w front (m/s²)``, or with ``by_name`` the name
        first, e.g. ``peak decel car 1 (g)`` (the gap's metrics)."""
        first = self.name if by_name else self.key
        return f"{' '.join(filter(None, (first, where)))} ({self.unit})"

    def value(self, row: Mapping[str, Any]) -> Any:
        """The value of ``row`` under the key or, in an older row, an alias."""
        for key in (self.key, *self.aliases):
            if key in row:
                return row[key]
        raise KeyError(self.key)

    def cell(self, row: Mapping[str, Any]) -> str:
        """The value of ``row`` formatted; an array (per floor point) joined by ``/``."""
        value = self.value(row)
        if np.ndim(value):
            return "/".join(format(float(v), self.fmt) for v in value)
        return format(float(value), self.fmt)


def metrics(table: Sequence[Metric], *keys: str) -> tuple[Metric, ...]:
    """The metrics of ``table`` with ``keys``, in that order."""
    by_key = {m.key: m for m in table}
    return tuple(by_key[k] for k in keys)


#: ``railgym/VerticalSuspension-v1``: means over the episodes of one case
VERTICAL = (
    Metric("rms_acc", "RMS ẍ2", "m/s²", "RMS carbody acceleration", ".3f", 12),
    Metric("a_w", "a_w Wk", "m/s²", "ISO 2631-1 Wk-weighted RMS carbody acceleration", ".3f", 12),
    Metric("a_w_reduction_%", "Δa_w", "%", "reduction of a_w against passive", ".1f", 7),
    Metric("Wz", "Wz", "", "Sperling ride index", ".2f", 6, aliases=("wz",)),
    Metric("max_defl_mm", "max |δ|", "mm", "largest suspension deflection", ".1f", 10),
    Metric("contacts", "contacts", "substeps", "bump-stop contact substeps", ".0f", 8, False),
)
#: ``railgym/VerticalVehicle-v1``: means over the episodes, per floor point (front, centre,
#: rear) where an array; the counts are totals
VEHICLE = (
    Metric("rms_acc", "RMS acc", "m/s²", "RMS floor acceleration", ".3f", 16),
    Metric("a_w", "a_w Wk", "m/s²", "ISO 2631-1 Wk-weighted RMS floor acceleration", ".3f", 16),
    Metric("a_w_reduction_%", "Δa_w", "%", "reduction of a_w against passive", ".1f", 17),
    Metric("a_ZP95_Wb", "a_ZP95 Wb", "m/s²", "EN 12299 comfort index", ".3f", 16),
    Metric("Wz", "Wz", "", "Sperling ride index", ".2f", 14),
    Metric("contacts", "contacts", "substeps", "bump-stop contact substeps", ".0f", 8, False),
    Metric(
        "ood", "out-dom", "evaluations", "surrogate evaluations outside its box", ".0f", 8, False
    ),
)
#: ``railgym/TrainCrash-v1``: crash criteria per car (decelerations) or zone (crush, intrusion)
CRASH = (
    Metric("peak_decel_g", "peak decel", "g", "peak deceleration of a car"),
    Metric("moving_average_g", "10 ms mean decel", "g", "peak 10 ms moving-average deceleration"),
    Metric("max_crush_m", "max crush", "m", "largest crush of a zone"),
    Metric("intrusion_m", "intrusion", "m", "survival-space intrusion of a zone"),
)
#: the crash envelope summary of a controller over the held-out cases
ENVELOPE = (
    Metric("peak_g", "mean worst-car peak", "g", "mean over the cases of the worst car's peak"),
    Metric("intrusion_le45_m", "max intrusion ≤ 45 km/h", "m", "largest intrusion up to 45 km/h"),
    Metric("intrusion_m", "max intrusion", "m", "largest intrusion"),
    Metric("excess_over_passive_m", "max excess over passive", "m", "intrusion beyond passive"),
    Metric("passed", "cases passing", "share", "share of cases passing every criterion"),
)
