"""The paper's published numbers (tables 3, 5, 6, 8, 11) shown beside ours in the report.

They come from a Simpack/LS-DYNA source and are not directly comparable with our models.
Table 10's degrees are not in our copy of the paper's text.
"""

from __future__ import annotations

from typing import Any

__all__ = ["PAPER", "PAPER_LABEL"]

#: label of every paper column
PAPER_LABEL = "paper (Simpack/LS-DYNA source; not directly comparable)"

#: errors are (displacement m, velocity m/s, acceleration m/s²); times (T_t s, T_s s)
PAPER: dict[str, Any] = {
    "table3": {"lpr": 1.92e-8, "kriging": 1.80e-5, "error_kind": "relative (eq. 8)"},
    "table5": {
        "lpr": {
            51: (2.44e-6, 2.38e-5, 5.67e-4),
            101: (2.44e-6, 2.38e-5, 5.67e-4),
            201: (2.38e-6, 2.38e-5, 5.91e-4),
        },
        "kriging": {
            51: (1.51e-5, 2.40e-5, 5.70e-4),
            101: (2.10e-5, 1.50e-4, 2.05e-3),
            201: (7.01e-6, 4.64e-5, 8.11e-4),
        },
    },
    "table6": {
        "lpr": {51: (0.08, 49.64), 101: (0.09, 48.31), 201: (0.08, 50.74)},
        "kriging": {51: (159.27, 256.35), 101: (372.17, 1593.78), 201: (1514.09, 9340.24)},
        "reference_s": 51.03,
    },
    "table8": {
        "lpr": {
            3: (4.33e-6, 3.68e-5, 6.70e-4),
            4: (2.70e-3, 2.96e-2, 3.55e-1),
            6: (5.97e-6, 8.57e-5, 4.22e-3),
        },
        "kriging": {
            3: (4.76e-4, 1.76e-3, 1.78e-2),
            4: (2.95e2, 5.51e1, 1.77e4),
            6: (5.52e-5, 9.42e-5, 2.07e-3),
        },
        "diverged": {"kriging": [4]},
    },
    "table11": {
        "lead": (0.0063, 0.0957, 8.7122),
        "passenger": (0.0061, 0.0752, 5.8602),
        "reference_s": 51548.0,
        "surrogate_s": 8.0,
    },
}
