"""Surrogate against reference of ``railgym/TrainCrash-v1`` across the envelope and the actions.

Both backends run the same episodes through the vector env (its absorber rate limit, control
step and crash end included): constant actions at every speed × the envelope's lightest and
heaviest payload (:func:`constant_action_cases`), and random action sequences at a few speeds
with payloads drawn from the envelope (:func:`random_action_cases`). Each case compares each
car's peak and 10 ms moving-average deceleration and each zone's largest crush
(:class:`MatrixCase`); ``railgym crash-report --matrix`` prints the table.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.controllers.crash_baselines import FixedActions, rollout
from railgym.envs.crash.env import TrainCrashVectorEnv
from railgym.vehicles.crash.surrogate import CrashSurrogate

__all__ = [
    "MATRIX_ACTIONS",
    "MATRIX_SPEEDS_KMH",
    "METRICS",
    "RANDOM_SEQUENCES",
    "RANDOM_SPEEDS_KMH",
    "MatrixCase",
    "constant_action_cases",
    "random_action_cases",
    "worst_errors",
]

#: speeds (km/h) and constant actions (every zone) of the constant-action matrix
MATRIX_SPEEDS_KMH = (25.0, 30.0, 35.0, 40.0, 45.0, 50.0)
MATRIX_ACTIONS = (-1.0, -0.5, 0.0, 0.5, 1.0)
#: speeds (km/h) and number of random action sequences per speed
RANDOM_SPEEDS_KMH = (30.0, 40.0, 50.0)
RANDOM_SEQUENCES = 20
#: compared metrics: each car's peak and 10 ms moving-average deceleration (g), each zone's
#: largest crush (m)
METRICS = ("peak_g", "moving_average_g", "max_crush_m")


@dataclass(frozen=True)
class MatrixCase:
    """One episode on both backends: speed (km/h), payload per car (t), a label of the
    actions, and per metric of :data:`METRICS` the reference and surrogate values (per car or
    per zone)."""

    speed_kmh: float
    payload_t: tuple[float, ...]
    actions: str
    reference: dict[str, np.ndarray]
    surrogate: dict[str, np.ndarray]

    def error(self, metric: str) -> np.ndarray:
        """Relative error of ``metric`` (per car or zone), surrogate against reference."""
        return self.surrogate[metric] / self.reference[metric] - 1.0


def _metrics(run: Any) -> dict[str, np.ndarray]:
    c = run.criteria()
    return {
        "peak_g": c.peak_decel_g,
        "moving_average_g": c.moving_average_g,
        "max_crush_m": run.crush.max(axis=0),
    }


class _Sequences:
    """Per sub-env action sequences ``(envs, holds, zones)``, each row held for ``hold``
    control steps (the last held to the end)."""

    def __init__(self, actions: np.ndarray, hold: int) -> None:
        self.actions, self.hold, self.k = actions.astype(np.float32), hold, 0

    def predict(self, observation: Any, **_: Any) -> tuple[np.ndarray, None]:
        j = min(self.k // self.hold, self.actions.shape[1] - 1)
        self.k += 1
        return self.actions[:, j], None


class _FirstMasses:
    """``controller`` that also keeps the env's car masses (kg) at its first call, i.e. those
    of the episodes :func:`rollout` records (later autoresets draw new ones)."""

    def __init__(self, env: TrainCrashVectorEnv, controller: Any) -> None:
        self.env, self.controller, self.masses = env, controller, np.zeros(0)

    def predict(self, observation: Any, **kw: Any) -> tuple[np.ndarray, None]:
        if self.masses.size == 0:
            self.masses = self.env.car_masses
        return self.controller.predict(observation, **kw)


def _both(
    controller: Any,
    num_envs: int,
    surrogate: CrashSurrogate | None,
    options: dict[str, Any],
    seed: int,
    env_kwargs: dict[str, Any],
) -> tuple[list[Any], list[Any], np.ndarray]:
    """Rollouts of ``controller`` on the reference and the surrogate vector env, and the
    payload (envs, cars) kg of each sub-env (the same on both, checked)."""
    runs, payloads = {}, {}
    for backend in ("reference", "surrogate"):
        env = TrainCrashVectorEnv(
            num_envs=num_envs,
            backend=backend,
            surrogate=surrogate if backend == "surrogate" else None,
            **env_kwargs,
        )
        first = _FirstMasses(env, controller() if callable(controller) else controller)
        runs[backend] = rollout(env, first, seed=seed, options=options)
        payloads[backend] = first.masses - env.cfg.scenario.car_masses
    if not np.allclose(payloads["reference"], payloads["surrogate"], rtol=0, atol=1e-6):
        raise RuntimeError("the two backends drew different payloads")
    return runs["reference"], runs["surrogate"], payloads["reference"]


def constant_action_cases(
    surrogate: CrashSurrogate | None = None,
    speeds_kmh: Sequence[float] = MATRIX_SPEEDS_KMH,
    actions: Sequence[float] = MATRIX_ACTIONS,
    scenario: str = "envelope",
    **env_kwargs: Any,
) -> list[MatrixCase]:
    """Each constant action (every zone) at each speed (km/h) × the envelope's lightest and
    heaviest payload (every car at the low, then the high end of its range); ``surrogate``
    ``None`` = the env's default elements."""
    kwargs = {"scenario": scenario, **env_kwargs}
    probe = TrainCrashVectorEnv(num_envs=1, backend="surrogate", surrogate=surrogate, **kwargs)
    rng = probe.cfg.payload_range
    if rng is None:
        raise ValueError(f"scenario {scenario!r} has no envelope (payload range)")
    nz = probe.single_action_space.shape[0]
    table = np.repeat(np.asarray(actions, dtype=np.float64)[:, None], nz, axis=1)
    cases = []
    for kmh in speeds_kmh:
        for end in (0, 1):
            payload_t = tuple(float(x) / 1e3 for x in rng[:, end])
            options = {"speed_kmh": kmh, "payload_t": list(payload_t)}
            ref, sur, _ = _both(FixedActions(table), len(actions), surrogate, options, 0, kwargs)
            for a, r, s in zip(actions, ref, sur, strict=True):
                cases.append(MatrixCase(kmh, payload_t, f"{a:+g}", _metrics(r), _metrics(s)))
    return cases


def random_action_cases(
    surrogate: CrashSurrogate | None = None,
    speeds_kmh: Sequence[float] = RANDOM_SPEEDS_KMH,
    n_sequences: int = RANDOM_SEQUENCES,
    seed: int = 0,
    scenario: str = "envelope",
    **env_kwargs: Any,
) -> list[MatrixCase]:
    """``n_sequences`` random action sequences at each speed (km/h), payloads drawn from the
    envelope by the env (seeded). Each zone's action is drawn uniformly from [−1, 1] and held
    for the absorber's full-swing time ``2 r / ṡ`` (30 ms with the defaults), so the scales
    sweep the whole range at the env's rate limit."""
    kwargs = {"scenario": scenario, **env_kwargs}
    probe = TrainCrashVectorEnv(num_envs=1, backend="surrogate", surrogate=surrogate, **kwargs)
    cfg = probe.cfg
    nz = probe.single_action_space.shape[0]
    hold = max(1, round(2 * cfg.absorber_range / cfg.max_scale_change))
    n_holds = cfg.n_steps // hold + 1
    gen = np.random.default_rng(seed)
    cases = []
    for i, kmh in enumerate(speeds_kmh):
        table = gen.uniform(-1.0, 1.0, (n_sequences, n_holds, nz))
        ref, sur, payload = _both(
            lambda t=table: _Sequences(t, hold),
            n_sequences,
            surrogate,
            {"speed_kmh": kmh},
            seed + i,
            kwargs,
        )
        for j, (r, s) in enumerate(zip(ref, sur, strict=True)):
            p = tuple(float(x) / 1e3 for x in payload[j])
            cases.append(MatrixCase(kmh, p, f"random {j}", _metrics(r), _metrics(s)))
    return cases


def worst_errors(cases: Sequence[MatrixCase]) -> dict[str, np.ndarray]:
    """Largest |relative error| of each metric over ``cases`` (per car or zone)."""
    return {m: np.max([np.abs(c.error(m)) for c in cases], axis=0) for m in METRICS}


def _signed_worst(errors: np.ndarray) -> np.ndarray:
    """Per column, the entry of ``errors`` (cases, columns) with the largest magnitude."""
    rows = np.argmax(np.abs(errors), axis=0)
    return errors[rows, np.arange(errors.shape[1])]


def matrix_table(constant: Sequence[MatrixCase], random: Sequence[MatrixCase]) -> str:
    """Markdown table of the largest relative error (signed, %) of each metric per car / zone:
    one row per speed × payload of the constant actions (largest over the actions), one per
    speed of the random sequences, and the largest |error| over each set."""
    names = {"peak_g": "peak", "moving_average_g": "10 ms", "max_crush_m": "crush"}
    n_cars = (
        constant[0].reference["peak_g"].size if constant else random[0].reference["peak_g"].size
    )
    cars = ["lead"] + [f"car {k + 1}" for k in range(1, n_cars)]
    zones = ["wall"] + [f"interface {k}" for k in range(1, n_cars)]
    heads = [f"{names[m]} {w}" for m in METRICS for w in (zones if m == "max_crush_m" else cars)]
    lines = [
        "| speed km/h | payload t | actions | " + " | ".join(heads) + " |",
        "|---|---|---|" + "---|" * len(heads),
    ]

    def row(group: Sequence[MatrixCase], speed: str, payload: str, actions: str) -> str:
        err = np.array([np.concatenate([c.error(m) for m in METRICS]) for c in group])
        cells = " | ".join(f"{100 * e:+.1f} %" for e in _signed_worst(err))
        return f"| {speed} | {payload} | {actions} | {cells} |"

    for label, cases in (("constant", constant), ("random", random)):
        keys = dict.fromkeys(
            (c.speed_kmh, c.payload_t if label == "constant" else None) for c in cases
        )
        for speed, payload in keys:
            group = [
                c
                for c in cases
                if c.speed_kmh == speed and (payload is None or c.payload_t == payload)
            ]
            p = " / ".join(f"{x:g}" for x in payload) if payload else "drawn"
            lines.append(row(group, f"{speed:g}", p, f"{len(group)} {label}"))
    for label, cases in (("constant actions", constant), ("random sequences", random)):
        if cases:
            w = worst_errors(cases)
            cells = " | ".join(f"{100 * e:.1f} %" for m in METRICS for e in w[m])
            lines.append(f"| **largest \\|error\\|** | | {label} | {cells} |")
    return "\n".join(lines)
