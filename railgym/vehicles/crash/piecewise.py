"""Piecewise crush-zone envelopes: one LPR per crush stage (:class:`PiecewiseEnvelope`).

A crush zone's loading envelope is a sequence of stages (draft gear, crush tube, a short ramp,
the main absorbers, a ramp, the carbody structure), with kinks between them that a single
polynomial over metres of crush cannot follow (it rings, and smooths a 30 mm ramp over
decimetres). :func:`fit_piecewise` fits one Legendre regression per stage, between knots at the
stage ends (the zone's design stroke points), each with its degree by 10-fold cross-validation.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from surrogates import io
from surrogates.selection import factory_for, select_kfold

__all__ = ["MIN_PIECE_SAMPLES", "OVERLAP", "PIECE_DEGREES", "PiecewiseEnvelope", "fit_piecewise"]

#: fewest training samples of a piece (a stage with fewer joins the next one)
MIN_PIECE_SAMPLES = 12
#: crush (m) beyond each knot whose samples a piece takes as well
OVERLAP = 2e-3
#: LPR degrees tried for each piece (those below its number of samples − 1): the longest
#: stages hold about ten folding waves; on the packaged elements degrees up to 64 gave the same
#: errors against the reference (docs/envs/crash.md) and cost kernel time, up to 32 did not
PIECE_DEGREES = (1, 2, 3, 4, 6, 8, 12, 16, 20, 24, 32, 40)


class PiecewiseEnvelope:
    """Envelope force (N) of the feature ``u`` (m) as one 1-input LPR per stage.

    ``pieces`` are ordered along ``u``; at ``u`` the first piece whose domain's upper end is
    at or above ``u`` applies (the last one beyond), as in the compiled kernels. The pieces
    clip outside their data (constant beyond their ends).
    """

    def __init__(self, pieces: Sequence[Any]) -> None:
        if not pieces:
            raise ValueError("a piecewise envelope needs at least one piece")
        self.pieces = list(pieces)

    @property
    def upper(self) -> np.ndarray:
        """Upper end of each piece's domain, m."""
        return np.array([float(p.kernel_arrays()[3][0]) for p in self.pieces])

    @property
    def degree(self) -> int:
        """Largest LPR degree of the pieces."""
        return max(self.degrees)

    @property
    def degrees(self) -> list[int]:
        """LPR degree of each piece."""
        return [int(p.kernel_arrays()[0].max()) for p in self.pieces]

    def piece_index(self, u: np.ndarray) -> np.ndarray:
        """Index of the piece that applies at each ``u`` (m)."""
        k = np.searchsorted(self.upper, np.asarray(u, dtype=np.float64), side="left")
        return np.minimum(k, len(self.pieces) - 1)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Force (N) at each row of ``X`` (n, 1), m."""
        u = np.asarray(X, dtype=np.float64).reshape(-1)
        out = np.empty(u.size)
        k = self.piece_index(u)
        for i, piece in enumerate(self.pieces):
            sel = k == i
            if sel.any():
                out[sel] = piece.predict(u[sel, None])
        return out

    def to_document(self) -> dict[str, Any]:
        """JSON document (the pieces as :func:`surrogates.io.model_to_document`)."""
        return {
            "kind": "piecewise",
            "pieces": [
                io.model_to_document(p, inputs=["u"], output="f", units={"u": "m", "f": "N"})
                for p in self.pieces
            ],
        }

    @classmethod
    def from_document(cls, doc: Any, where: str) -> PiecewiseEnvelope:
        """Inverse of :meth:`to_document`; ``where`` names the document in errors."""
        pieces = doc.get("pieces") if isinstance(doc, dict) else None
        if not isinstance(pieces, list) or not pieces:
            raise ValueError(f"{where}: field 'pieces' must be a non-empty list")
        return cls(
            [io.model_from_document(p, f"{where}.pieces[{i}]") for i, p in enumerate(pieces)]
        )


def fit_piecewise(
    u: np.ndarray,
    f: np.ndarray,
    knots: Sequence[float],
    seed: int = 0,
    degrees: Sequence[int] = PIECE_DEGREES,
    rise: bool = True,
) -> tuple[PiecewiseEnvelope, list[Any]]:
    """One LPR per stage of ``f(u)`` (N of m) between ``knots`` (m), each degree by 10-fold CV
    among ``degrees``; a stage with fewer than :data:`MIN_PIECE_SAMPLES` samples joins the next
    (the last joins the one before); each piece also takes the samples within :data:`OVERLAP`
    beyond its knots. ``rise``: below the first knot the envelope is the straight line from the
    origin to the first stage's force there (the zone's first rise, which the sampled crush
    runs through within a fraction of a sample), and the samples there are not used. Returns
    the envelope and each fitted piece's selection table."""
    u, f = np.asarray(u, dtype=np.float64), np.asarray(f, dtype=np.float64)
    if rise:
        keep = u >= min(knots)
        u, f = u[keep], f[keep]
    edges = np.unique(np.asarray([k for k in knots if u.min() < k < u.max()], dtype=np.float64))
    piece = np.searchsorted(edges, u, side="left")
    bounds = np.concatenate(([-np.inf], edges, [np.inf]))
    spans: list[list[float]] = []  # [low, high] knot range of each piece
    count, low = 0, -np.inf
    for k in range(edges.size + 1):
        count += int(np.count_nonzero(piece == k))
        if count >= MIN_PIECE_SAMPLES:
            spans.append([low, bounds[k + 1]])
            count, low = 0, bounds[k + 1]
    if count:
        if not spans:
            raise ValueError(f"too few training samples ({u.size}) to fit an envelope")
        spans[-1][1] = np.inf
    make = factory_for("lpr", extrapolation="clip")
    pieces, tables = [], []
    for low, high in spans:
        # the samples just beyond each knot as well: the pieces' domains overlap, no gap
        sel = (u >= low - OVERLAP) & (u <= high + OVERLAP)
        n = int(np.count_nonzero(sel))
        cands = [int(d) for d in degrees if 1 <= d <= n - 2] or [1]
        res = select_kfold(make, cands, u[sel, None], f[sel], k=min(10, n), seed=seed)
        pieces.append(make(res.best).fit(u[sel, None], f[sel]))
        tables.append(res)
    if rise:  # linear from the origin to the first stage's force at the first knot
        k0 = float(min(knots))
        f0 = float(pieces[0].predict(np.array([[k0]]))[0])
        line = factory_for("lpr", extrapolation="clip")(1).fit(np.array([[0.0], [k0]]), [0.0, f0])
        pieces.insert(0, line)
    return PiecewiseEnvelope(pieces), tables
