"""Bump-stop contacts as part of the score: which policy of a results table (a trained one)
has a better comfort index ``a_w`` than a baseline of the same case (a classical controller)
but more bump-stop contacts (substeps with the deflection beyond the free travel,
``info["bump_stop_contacts"]``).

A lower ``a_w`` bought with harder hits on the bump stops is no plain improvement: the tables
of ``railgym evaluate`` (:mod:`agents.evaluation.evaluate`), of the benchmark
(:mod:`agents.evaluation.benchmark`) and of the transfer gap (:mod:`agents.evaluation.gap`) say so
beside the numbers (:func:`contact_note`).
"""

from __future__ import annotations

from collections.abc import Collection, Hashable, Sequence
from typing import NamedTuple

__all__ = ["Score", "contact_note", "more_contacts"]


class Score(NamedTuple):
    """One row of a results table: its case, its policy, ``a_w`` (m/s²; a vehicle's: the mean
    over its floor points) and its bump-stop contacts (substeps)."""

    case: Hashable
    policy: str
    a_w: float
    contacts: float


def more_contacts(scores: Sequence[Score], baselines: Collection[str]) -> list[list[str]]:
    """Per score of a policy (a trained one: not in ``baselines``, the names of the classical
    controllers), the baselines of the same case whose ``a_w`` it beats with more bump-stop
    contacts, in the table's order; a baseline's own score gets none."""
    return [
        []
        if s.policy in baselines
        else [
            b.policy
            for b in scores
            if b.policy in baselines
            and b.case == s.case
            and s.a_w < b.a_w
            and s.contacts > b.contacts
        ]
        for s in scores
    ]


def contact_note(names: Sequence[str]) -> str:
    """``"more contacts than lqg, skyhook"`` (the baselines of :func:`more_contacts`), ``""``
    for none."""
    return f"more contacts than {', '.join(names)}" if names else ""
