"""Space-filling sampling (paper section 3.2): time and achieved maximin distance.

Data: 1001 uniform random points in [0, 1]² (the size of the paper's vertical-dynamics data,
20 s at 50 Hz), of which M = 101 are chosen by the GA, by greedy farthest-point maximin and at
random; plus the paper's own demonstration, 36 of 1600 random points. Distances are in the unit
square; the random choice is averaged over 5 seeds. Times exclude numba compilation.
"""

from __future__ import annotations

import time

import numpy as np

from surrogates.sampling import min_distance, select

CONTEXT = "paper: GA, 36 of 1600 points"


def _timed(X: np.ndarray, m: int, method: str, seed: int = 0) -> tuple[float, np.ndarray]:
    t0 = time.perf_counter()
    train, _ = select(X, m, method, seed=seed)
    return time.perf_counter() - t0, train


def run() -> list[dict]:
    """Rows ``{"name", "value", "unit", "target", "context"}``."""
    rows: list[dict] = []
    select(np.random.default_rng(1).random((50, 2)), 5, "ga", seed=0, generations=2)  # compile
    for n, m in ((1001, 101), (1600, 36)):
        X = np.random.default_rng(0).random((n, 2))
        t_ga, ga = _timed(X, m, "ga")
        t_greedy = min(_timed(X, m, "greedy")[0] for _ in range(5))
        d_ga, d_greedy = min_distance(X, ga), min_distance(X, _timed(X, m, "greedy")[1])
        d_rand = float(np.mean([min_distance(X, _timed(X, m, "random", s)[1]) for s in range(5)]))
        tag = f"{m}_of_{n}"
        main = (n, m) == (1001, 101)
        rows += [
            {
                "name": f"sampling_ga_time_{tag}",
                "value": t_ga,
                "unit": "s",
                "target": "<= 2 s" if main else "paper setup",
                "context": CONTEXT,
            },
            {
                "name": f"sampling_greedy_time_{tag}",
                "value": t_greedy,
                "unit": "s",
                "target": "<= 0.05 s" if main else "paper setup",
                "context": CONTEXT,
            },
            {
                "name": f"sampling_min_dist_ga_{tag}",
                "value": d_ga,
                "unit": "-",
                "target": ">= greedy",
                "context": CONTEXT,
            },
            {
                "name": f"sampling_min_dist_greedy_{tag}",
                "value": d_greedy,
                "unit": "-",
                "target": ">= random",
                "context": CONTEXT,
            },
            {
                "name": f"sampling_min_dist_random_{tag}",
                "value": d_rand,
                "unit": "-",
                "target": "baseline",
                "context": f"{CONTEXT}; mean of 5 seeds",
            },
            {
                "name": f"sampling_ga_over_random_{tag}",
                "value": d_ga / d_rand,
                "unit": "x",
                "target": "> 1",
                "context": CONTEXT,
            },
            {
                "name": f"sampling_greedy_over_random_{tag}",
                "value": d_greedy / d_rand,
                "unit": "x",
                "target": "> 1",
                "context": CONTEXT,
            },
        ]
    return rows


if __name__ == "__main__":
    for row in run():
        print(
            f"{row['name']:40s} {row['value']:12.4g} {row['unit']:2s}  "
            f"[{row['target']}] {row['context']}"
        )
