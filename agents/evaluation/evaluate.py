"""``railgym evaluate``: comfort indices of any controller or saved policy, beside passive and
skyhook, on the vertical env (one bogie) and on the whole vehicle (comfort at the front, centre
and rear floor points); crash-safety indices beside the passive absorbers on the crash env, or
over the held-out impact envelope beside the crash baselines.

    railgym evaluate skyhook --backend reference --track-class 4 6 --episodes 10
    railgym evaluate runs/ppo_vertical/model.zip --backend reference --track-class 4 6
    railgym evaluate modal-skyhook lqr --env vehicle --track-class 5 --speed-kmh 60 100 144 200
    railgym evaluate runs/ppo_crash/model.zip --env crash --speed-kmh 36 40 44
    railgym evaluate runs/ppo_crash/model.zip --env crash --envelope
    railgym evaluate clipped-lqg skyhook-onoff groundhook --actuator semi-active

``--env-id ID`` (or ``--env-version N``) runs the episodes on that registered version of the
env of ``--env`` (default: its newest version, ``VerticalSuspension-v3``, ``VerticalVehicle-v3``,
``TrainCrash-v1``; the table's header names the id).

Without ``--actuator`` the command takes the actuator a trained policy was trained with (its
run's settings; e.g. ``ppo-semiactive``: the damper), so that its comparison rows run on the
same actuator; an ``--actuator`` other than a trained policy's is refused.

A policy is a controller name (vertical: ``passive``, ``skyhook``, ``semi-active``,
``groundhook``, ``lqr``, ``lqg``; with ``--actuator semi-active``, the command of the env's
controllable damper: ``passive`` (command 0), ``constant-max``, ``skyhook-onoff``, ``skyhook``,
``groundhook``, ``clipped-lqg`` of :mod:`agents.controllers.semi_active_control`, and a controller
of the other actuator is refused; vehicle: ``passive``, ``skyhook`` (skyhook per bogie),
``modal-skyhook``, ``lqr``, ``lqg``, and with ``--actuator semi-active`` the same damper
controllers per bogie) or a stable-baselines3 ``.zip``: of :mod:`agents.training.train` (its
``model.zip`` or a checkpoint ``checkpoints/model_N_steps.zip``: the algorithm and the env's
observation settings from the run's ``config.yaml``), of rl-zoo3 (the run's ``args.yml`` and
``config.yml``) or any other (the algorithm and network from the zip's JSON ``data``; the env
from the flags), see :mod:`agents.policies.policy_zip`. The zip must be listed with its SHA-256 in
the ``manifest.json`` beside it (``--trust``: any zip, e.g. rl-zoo3's, with a warning), and only
its network weights are read (:mod:`agents.policies.policy_io`). Each case (track class, and speed
on the vehicle) runs ``episodes`` episodes in one native vector env, sub-env ``i`` on the track
of seed ``seed + i`` — the same tracks for every policy. ``--workers N`` / ``--address ADDR``
run the cases of the vertical and vehicle evaluations as parallel tasks
(:func:`railgym.parallel.run_tasks`); the rows do not depend on the number of workers.

The command always adds rows to compare against, whether or not they are named: ``passive``
and ``skyhook`` on the vertical env and the vehicle (first, in that order; the Δa_w column is
the reduction against passive), ``passive`` on the crash env (Δpeak against it), and the three
crash baselines ``passive``, ``best-constant``, ``speed-adaptive`` with ``--envelope``. Naming
one of them as well adds no second row. Beside ``a_w`` the vertical and vehicle tables give the
bump-stop contacts (substeps), and a column ``note`` says where a trained policy's ``a_w`` beats
a classical controller's with more contacts (:mod:`agents.evaluation.contacts`). A crash run that
the env cut as diverged (``info["diverged"]``) is marked in the table and named in a line under it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from agents.commands.flags import (
    backend_kwargs,
    check_speed_kmh,
    with_policy_kwargs,
)
from agents.controllers.registry import (
    BASELINES,
    CONTROLLERS,
    CRASH_ID,
    ENV_ID,
    VEHICLE_CONTROLLERS,
    VEHICLE_ID,
    crash_factories,
)
from agents.evaluation import crash_report
from agents.evaluation.contacts import Score, contact_note, more_contacts
from agents.evaluation.metrics import VEHICLE, VERTICAL, Metric
from agents.policies.loading import load_policy
from railgym import _checks as val
from railgym.progress import bar

__all__ = [
    "ENV_IDS",
    "evaluate_crash",
    "evaluate_envelope",
    "format_crash_rows",
    "format_rows",
    "format_vehicle_rows",
]


#: the env id of each ``--env`` without ``--env-id`` / ``--env-version``: its newest version
ENV_IDS = {"vertical": ENV_ID, "vehicle": VEHICLE_ID, "crash": CRASH_ID}


def _aligned(columns: Sequence[tuple[str, str, int]], cells: list[list[str]]) -> str:
    """A text table: columns ``(title, align, least width)`` (align ``"<"`` or ``">"``), each
    as wide as its title and its widest cell (a long policy name widens its column)."""
    widths = [
        max([least, len(title), *(len(row[k]) for row in cells)])
        for k, (title, _, least) in enumerate(columns)
    ]

    def line(values: Sequence[str]) -> str:
        parts = zip(values, columns, widths, strict=True)
        return " ".join(f"{v:{align}{w}}" for v, (_, align, _), w in parts).rstrip()

    return "\n".join([line([c[0] for c in columns]), *(line(row) for row in cells)])


#: columns of the surrogate's validity flags (docs/validation.md, *Validity flags*): the share
#: of steps with an element input outside its training box, and the case against the
#: element's operating envelope
VALIDITY_COLUMNS = [("out-box %", ">", 9), ("envelope", ">", 8)]


def _with_validity(
    rows: list[dict[str, Any]], columns: list[tuple[str, str, int]], cells: list[list[str]]
) -> tuple[list[tuple[str, str, int]], list[list[str]]]:
    """``columns`` and ``cells`` with :data:`VALIDITY_COLUMNS` added where a row ran the
    surrogate backend (``-`` in the others' rows: they never flag)."""
    if not any(r.get("backend") == "surrogate" for r in rows):
        return columns, cells

    def flags(r: dict[str, Any]) -> list[str]:
        if r.get("backend") != "surrogate":
            return ["-", "-"]
        return [f"{r['outside_element_%']:.3g}", "outside" if r["outside_envelope"] else "inside"]

    return columns + VALIDITY_COLUMNS, [c + flags(r) for c, r in zip(cells, rows, strict=True)]


def _with_contact_notes(
    scores: list[Score],
    baselines: Sequence[str],
    columns: list[tuple[str, str, int]],
    cells: list[list[str]],
) -> tuple[list[tuple[str, str, int]], list[list[str]]]:
    """``columns`` and ``cells`` with a column ``note`` where a trained policy's ``a_w`` beats
    a baseline's of its case (a classical controller: a name of ``baselines``) with more
    bump-stop contacts (:func:`agents.evaluation.contacts.more_contacts`): ``more contacts than
    lqg``."""
    notes = [contact_note(names) for names in more_contacts(scores, baselines)]
    if not any(notes):
        return columns, cells
    return columns + [("note", "<", 4)], [c + [n] for c, n in zip(cells, notes, strict=True)]


def _metric_columns(table: Sequence[Metric]) -> list[tuple[str, str, int]]:
    """Text-table columns of the metrics ``table``: title, right-aligned, least width."""
    return [(m.title, ">", m.width) for m in table]


def format_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`agents.evaluation.sweeps.evaluate_sweep` rows, the metrics
    of :data:`agents.evaluation.metrics.VERTICAL` (each column as wide as its widest entry; on
    the surrogate backend with :data:`VALIDITY_COLUMNS`; a column ``note`` names the classical
    controllers a trained policy beats in ``a_w`` with more bump-stop contacts)."""
    columns = [("class", ">", 5), ("policy", "<", 16), *_metric_columns(VERTICAL)]
    cells = [
        [str(r["track_class"]), str(r["policy"]), *(m.cell(r) for m in VERTICAL)] for r in rows
    ]
    scores = [Score(r["track_class"], str(r["policy"]), r["a_w"], r["contacts"]) for r in rows]
    return _aligned(
        *_with_contact_notes(scores, list(CONTROLLERS), *_with_validity(rows, columns, cells))
    )


def format_vehicle_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`evaluate_vehicle` rows, the metrics of
    :data:`agents.evaluation.metrics.VEHICLE`, front / centre / rear per index (each column as
    wide as its widest entry; on the surrogate backend with :data:`VALIDITY_COLUMNS`; a column
    ``note`` names the classical controllers a trained policy beats in ``a_w``, the mean over
    the floor points, with more bump-stop contacts)."""
    columns = [("class", ">", 5), ("km/h", ">", 5), ("policy", "<", 14), *_metric_columns(VEHICLE)]
    cells = [
        [
            str(r["track_class"]),
            f"{r['speed_kmh']:.0f}",
            str(r["policy"]),
            *(m.cell(r) for m in VEHICLE),
        ]
        for r in rows
    ]
    scores = [
        Score(
            (r["track_class"], r["speed_kmh"]),
            str(r["policy"]),
            float(np.mean(r["a_w"])),
            r["contacts"],
        )
        for r in rows
    ]
    notes = _with_contact_notes(
        scores, list(VEHICLE_CONTROLLERS), *_with_validity(rows, columns, cells)
    )
    return _aligned(*notes)


# ================================================================ railgym/TrainCrash-v1
def evaluate_crash(
    policies: Sequence[str],
    backend: str = "reference",
    speeds_kmh: Sequence[float] | None = None,
    trust: bool = False,
    env_kwargs: dict[str, Any] | None = None,
    env_id: str = CRASH_ID,
) -> list[dict[str, Any]]:
    """One row per (speed, policy): episode-end crash-safety indices of ``env_id`` (a version
    of ``railgym/TrainCrash``; ``trust``: see :func:`load_policy`); ``env_kwargs`` (e.g. the
    user's ``scenario``, ``surrogate``) are added to each policy's training settings;
    ``speeds_kmh`` ``None``:
    each env's scenario speed (its ``speed_kmh``). ``diverged``: the env cut the run where its
    state diverged (``info["diverged"]``), the indices are those at the cut; ``scenario``: the
    :class:`~railgym.vehicles.crash.scenario.CrashScenario` each row ran."""
    speeds: list[float | None] = (
        [None]
        if speeds_kmh is None
        else [check_speed_kmh(v, "speeds_kmh") for v in val.sequence(speeds_kmh, "speeds_kmh")]
    )
    rows = []
    extra = dict(env_kwargs or {})
    loaded = [
        load_policy(p, env_id, trust) if p != "passive" else (None, {}, "passive")
        for p in val.sequence(policies, "policies")
    ]
    for v in bar(speeds, desc="speeds"):
        passive = None
        for factory, env_kwargs, label in loaded:
            # the speed as a reset option: the observation keeps the scales the policy was
            # trained with (an explicit `speed` would rescale an envelope's velocities)
            kwargs = with_policy_kwargs(env_kwargs, backend_kwargs(backend, extra), label)
            env = gym.make(env_id, backend=backend, **kwargs)
            scenario = env.unwrapped.cfg.scenario
            kmh = 3.6 * scenario.speed if v is None else v
            ctrl = factory(env) if factory else None
            obs, _ = env.reset(seed=0, options={"speed_kmh": kmh})
            while True:
                if ctrl is None:
                    action = np.zeros(env.action_space.shape or (), np.float32)
                else:
                    action, _ = ctrl.predict(obs, deterministic=True)
                obs, _, term, trunc, info = env.step(action)
                if term or trunc:
                    break
            peak = float(np.max(info["peak_decel_g"]))
            passive = peak if label == "passive" else passive
            rows.append(
                {
                    "speed_kmh": kmh,
                    "scenario": scenario,
                    "policy": label,
                    "peak_decel_g": info["peak_decel_g"],
                    "max_crush_m": info["max_crush_m"],
                    "stroke_exceeded": bool(info["stroke_exceeded"]),
                    "diverged": bool(info["diverged"]),
                    "peak_reduction_%": 100 * (1 - peak / passive) if passive else float("nan"),
                }
            )
    return rows


def evaluate_envelope(
    policies: Sequence[str],
    speeds_kmh: Sequence[float] | None = None,
    trust: bool = False,
    env_kwargs: dict[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """The held-out envelope evaluation of ``TrainCrash-v1`` on the reference backend
    (:func:`agents.evaluation.crash_report.envelope_rows`): the passive absorbers, the best constant
    setting, the speed-adaptive rule and each trained policy ``.zip`` of ``policies`` (the
    baseline names ``passive``, ``best-constant``, ``speed-adaptive`` there are accepted; the
    three always run) at ``speeds_kmh`` (default the held-out speeds of the scenario's
    envelope, :func:`~agents.evaluation.crash_report.envelope_cases`) × its lightest and
    heaviest payloads; ``env_kwargs`` (the user's ``scenario``) join the policies' training
    settings (another value than a policy's is an error naming it)."""
    speeds = (
        None
        if speeds_kmh is None
        else [check_speed_kmh(v, "speeds_kmh") for v in val.sequence(speeds_kmh, "speeds_kmh")]
    )
    factories = crash_factories(BASELINES[CRASH_ID])
    kwargs = dict(env_kwargs or {})
    trained: dict[str, Any] | None = None
    for p in val.sequence(policies, "policies"):
        if crash_factories([p]):
            continue
        factory, settings, label = load_policy(p, CRASH_ID, trust)
        if trained is not None and settings != trained:
            raise ValueError(
                f"policy {p}: trained with env settings {settings}, another policy with "
                f"{trained}; evaluate them in separate runs"
            )
        trained, factories[label] = settings, factory
        kwargs = with_policy_kwargs(settings, kwargs, label)
    return crash_report.envelope_rows(factories, kwargs, speeds)


def crash_header(
    rows: list[dict[str, Any]], backend: str, speed_flag: bool, env_id: str = CRASH_ID
) -> str:
    """The line over :func:`format_crash_rows`: ``env_id``, the train(s) the rows ran
    (scenario, cars, the scenario's speed) and, where ``--speed-kmh`` was given
    (``speed_flag``), that it overrides that speed."""
    speeds = (
        "impact speeds from --speed-kmh (override the scenario's speed_kmh)"
        if speed_flag
        else "impact speed: the scenario's speed_kmh"
    )
    return (
        f"{env_id}, {crash_report.trains_of(rows)}, backend: {backend}; {speeds}; Δpeak: "
        "reduction of the largest car deceleration vs the passive absorbers"
    )


def format_crash_rows(rows: list[dict[str, Any]]) -> str:
    """Aligned text table of :func:`evaluate_crash` rows (each column as wide as its widest
    entry); a run the env cut as diverged is marked in the column ``diverged`` and named in a
    line under the table."""
    columns = [
        ("km/h", ">", 5),
        ("policy", "<", 16),
        ("peak decel per car (g)", "<", 24),
        ("Δpeak %", ">", 7),
        ("max crush per zone (m)", "<", 24),
        ("stroke exceeded", "<", 15),
        ("diverged", "<", 8),
    ]
    cells = [
        [
            f"{r['speed_kmh']:.0f}",
            str(r["policy"]),
            " ".join(f"{x:.2f}" for x in np.atleast_1d(r["peak_decel_g"])),
            f"{r['peak_reduction_%']:.1f}",
            " ".join(f"{x:.3f}" for x in np.atleast_1d(r["max_crush_m"])),
            str(r["stroke_exceeded"]),
            "yes" if r.get("diverged", False) else "no",
        ]
        for r in rows
    ]
    cut = [f"{r['policy']} at {r['speed_kmh']:g} km/h" for r in rows if r.get("diverged", False)]
    return "\n".join([_aligned(columns, cells), *crash_report.diverged_lines(cut)])
