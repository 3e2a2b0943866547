"""Crash surrogate elements from a user's FE crash model (LS-DYNA output), and their JSON files.

The paper learns its crash elements (eq. 4) from an LS-DYNA run. Here the run's ASCII output is
read by :mod:`surrogates.lsdyna` and turned into the time histories railgym's own reference model
produces, so that :func:`railgym.vehicles.crash.surrogate.build_crash_surrogate` fits the
elements exactly as it does on :func:`~railgym.vehicles.crash.reference.simulate_reference`
results, and
``gym.make("railgym/TrainCrash-v1", surrogate=elements)`` runs on them.

What is taken from the FE output (:func:`crash_result_from_fe`):

* ``nodout``: one node per car (lead car first), ideally at the car's centre of mass or on a
  rigid part of its underframe; its displacement along the travel ``axis`` (times
  ``direction`` = ±1, so that positive is towards the wall), re-zeroed at ``start_time``
  (default the first sample: the FE run should start at first contact), is the car's ``x``;
  its velocity and acceleration give ``v`` and ``a``;
* ``rcforc``: the wall contact and one contact per car interface; a contact only pushes, so
  the zone force is ``|F_axis|`` of the contact's master side (the slave side if the file has
  no master line for it), interpolated linearly onto the nodout times.

The crash features follow :func:`~railgym.vehicles.crash.surrogate.crash_training_data`: the wall
element sees ``u = x_lead`` (rigid wall at rest) and ``f_1`` the wall force, the interface element
``u = x_{k+1} − x_k`` (the paper's ``x_1 − x_2`` with railgym's sign, compression positive)
and ``f_2``, both split into loading and unloading branches by the crush rate. A zone's own
crush (what elements of cars with an elastic carbody learn, ``nodes_per_car > 1``) is that
centre-of-mass feature less the carbodies' elastic shortening between each car's centre of
mass and its ends (:func:`carbody_shortening`), so that the elements hold the zone's own
unloading stiffness, not that of the zone and the carbodies in series. The masses, speed,
carbodies and zone layout of the env come from ``scenario``: give the scenario of the FE
model (its ``n_cars`` must match the car nodes).

:func:`export_crash_element_fmu` writes one element, memory included, as an FMI 2.0
co-simulation FMU (see ``docs/fmi.md``).

:func:`save_crash_surrogate` / :func:`load_crash_surrogate` write and read a
:class:`~railgym.vehicles.crash.surrogate.CrashSurrogate` as JSON (each LPR as a
:func:`surrogates.io.model_to_document`). Command line::

    railgym crash-fe --nodout nodout --rcforc rcforc --unit-system mm-ms-kg-kN \\
        --scenario my_train.yaml --car-nodes 1001 2001 --wall-contact 1 \\
        --interface-contacts 2 -o elements.json [--fmu-dir fmus/]
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from railgym import _checks as val
from railgym.vehicles.crash.outputs import CrashResult
from railgym.vehicles.crash.piecewise import PiecewiseEnvelope
from railgym.vehicles.crash.scenario import CrashScenario, load_scenario
from railgym.vehicles.crash.surrogate import MAX_NODES_PER_CAR as MAX_NODES
from railgym.vehicles.crash.surrogate import (
    CrashElement,
    CrashFitOptions,
    CrashSurrogate,
    build_crash_surrogate,
)
from surrogates import io
from surrogates.features import TimeHistory
from surrogates.models.base import jsonable
from surrogates.selection import SelectionResult

__all__ = [
    "AXES",
    "FORMAT",
    "SCHEMA_VERSION",
    "carbody_shortening",
    "crash_result_from_fe",
    "crash_surrogate_from_fe",
    "export_crash_element_fmu",
    "load_crash_surrogate",
    "save_crash_surrogate",
]

AXES = ("x", "y", "z")
FORMAT = "railgym-crash-surrogate"
SCHEMA_VERSION = 1


def _contact_force(
    contacts: Mapping[tuple[str, int], TimeHistory], cid: int, axis: str, t: np.ndarray
) -> np.ndarray:
    """``|F_axis|`` (N) of contact ``cid`` (master side, else slave) at the times ``t``."""
    key = ("master", cid) if ("master", cid) in contacts else ("slave", cid)
    th = contacts.get(key)
    if th is None:
        have = sorted({k[1] for k in contacts})
        raise ValueError(f"contact {cid} is not in the rcforc data; it has contacts {have}")
    return np.abs(np.interp(t, th.t, th[f"{axis}_force"]))


def _check_fe_ids(
    nodes: Mapping[int, TimeHistory],
    car_nodes: Sequence[int],
    interface_contacts: Sequence[int],
    scenario: CrashScenario,
) -> tuple[list[int], list[int]]:
    """``car_nodes`` and ``interface_contacts`` as int lists, checked against each other, the
    ``scenario``'s number of cars and the nodout ``nodes`` (one sample grid for all cars);
    ``ValueError`` naming them."""
    car_nodes = [int(n) for n in car_nodes]
    interface_contacts = [int(c) for c in interface_contacts]
    if len(car_nodes) < 2:
        raise ValueError(f"car_nodes needs one node per car and at least 2 cars, got {car_nodes}")
    if len(car_nodes) != scenario.n_cars:
        raise ValueError(
            f"car_nodes has {len(car_nodes)} nodes (one per car) but scenario "
            f"{scenario.name!r} has {scenario.n_cars} cars (its crash.n_cars); give the "
            "scenario of the FE model, or one node per car of it"
        )
    if len(interface_contacts) != len(car_nodes) - 1:
        raise ValueError(
            f"interface_contacts needs {len(car_nodes) - 1} ids (one per interface), "
            f"got {interface_contacts}"
        )
    missing = [n for n in car_nodes if n not in nodes]
    if missing:
        raise ValueError(f"car_nodes {missing} are not in the nodout data; it has {sorted(nodes)}")
    t = nodes[car_nodes[0]].t
    for n in car_nodes[1:]:
        if not np.array_equal(nodes[n].t, t):
            raise ValueError(f"node {n} has other sample times than node {car_nodes[0]}")
    return car_nodes, interface_contacts


def _fe_window(t: np.ndarray, contact_times: list[np.ndarray], start_time: float | None) -> Any:
    """Mask of the nodout times ``t`` (s) from ``start_time`` (default ``t[0]``) within the
    times of every used contact; ``ValueError`` for fewer than 3 samples."""
    t_end = min((tc[-1] for tc in contact_times), default=np.inf)
    t_beg = max((tc[0] for tc in contact_times), default=-np.inf)
    t0 = t[0] if start_time is None else float(start_time)
    keep = (t >= t0) & (t >= t_beg) & (t <= t_end)
    if np.count_nonzero(keep) < 3:
        raise ValueError(
            f"fewer than 3 nodout samples from start_time {t0} s within the rcforc times "
            f"[{t_beg}, {t_end}] s"
        )
    return keep


def carbody_shortening(scenario: CrashScenario, t: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Elastic shortening (m) of each car between its centre of mass and its front end
    (column ``2k``) and its rear end (column ``2k + 1``) at the times ``t`` (s) under the zone
    forces ``force`` ((samples, zones) N, wall first, compression positive).

    Each car is the scenario's carbody (``n_nodes`` lumped masses, row-sum lumping, links
    ``EA / ℓ`` with damping ratio ``ζ``, as the reference model's), undeformed at ``t[0]``,
    pushed back at its front node by its front zone and forward at its rear node by the zone
    behind it (forces linear between the samples); friction proportional to mass decelerates
    it without deforming it. Quasi-statically a uniform car shortens by
    ``L (F_f/3 + F_r/6) / EA`` to the front and ``L (F_f/6 + F_r/3) / EA`` to the rear; the
    integration keeps the stress waves of a fast unloading, which that misses.
    """
    n = scenario.n_cars
    cars = [scenario.lead] + [scenario.passenger] * (n - 1)
    out = np.zeros((t.size, 2 * n))
    for k, car in enumerate(cars):
        front = force[:, k]
        rear = force[:, k + 1] if k + 1 < n else np.zeros_like(front)
        m = np.full(car.n_nodes, car.mass / (car.n_nodes - 1))
        m[[0, -1]] *= 0.5
        k_link = car.axial_rigidity * (car.n_nodes - 1) / car.length
        c_link = 2 * car.damping_ratio * np.sqrt(k_link * m[:-1] * m[1:] / (m[:-1] + m[1:]))
        x = _driven_chain(m, k_link, c_link, t, front, rear)
        com = x @ m / m.sum()
        out[:, 2 * k] = com - x[:, 0]
        out[:, 2 * k + 1] = x[:, -1] - com
    return out


def _driven_chain(
    m: np.ndarray,
    k_link: float,
    c_link: np.ndarray,
    t: np.ndarray,
    front: np.ndarray,
    rear: np.ndarray,
) -> np.ndarray:
    """Node displacements (samples, nodes) m of a chain of masses ``m`` (kg) joined by links
    ``k_link`` (N/m) and ``c_link`` (N s/m), at rest at ``t[0]``, with ``−front`` on its first
    node and ``+rear`` on its last (N at the times ``t``): velocity Verlet at a tenth of the
    chain's stable step."""
    dt_max = 0.2 / np.sqrt(4.0 * k_link / m.min())
    x, v = np.zeros(m.size), np.zeros(m.size)
    out = np.zeros((t.size, m.size))

    def accel(x: np.ndarray, v: np.ndarray, ff: float, fr: float) -> np.ndarray:
        link = k_link * np.diff(x) + c_link * np.diff(v)  # tension of each link
        f = np.zeros(m.size)
        f[:-1] += link
        f[1:] -= link
        f[0] -= ff
        f[-1] += fr
        return f / m

    a = accel(x, v, front[0], rear[0])
    for i in range(1, t.size):
        steps = max(1, int(np.ceil((t[i] - t[i - 1]) / dt_max)))
        h = (t[i] - t[i - 1]) / steps
        for j in range(1, steps + 1):
            w = j / steps
            ff = (1 - w) * front[i - 1] + w * front[i]
            fr = (1 - w) * rear[i - 1] + w * rear[i]
            v_half = v + 0.5 * h * a
            x = x + h * v_half
            a = accel(x, v_half + 0.5 * h * a, ff, fr)
            v = v_half + 0.5 * h * a
        out[i] = x
    return out


def crash_result_from_fe(
    nodes: Mapping[int, TimeHistory],
    contacts: Mapping[tuple[str, int], TimeHistory],
    *,
    car_nodes: Sequence[int],
    wall_contact: int,
    interface_contacts: Sequence[int],
    scenario: CrashScenario | str | Path,
    axis: str = "x",
    direction: float = 1.0,
    start_time: float | None = None,
) -> CrashResult:
    """FE output (:func:`surrogates.io.read_nodout`, :func:`~surrogates.io.read_rcforc`) as
    the :class:`CrashResult` that :func:`build_crash_surrogate` learns from.

    Parameters
    ----------
    nodes, contacts : the readers' output (SI).
    car_nodes : node id of each car, lead car first (``n_cars`` ids).
    wall_contact : contact id of the wall (or obstacle) contact.
    interface_contacts : contact id of each car interface, front to back (``n_cars − 1``).
    scenario : the scenario of the FE model (masses, carbodies and zones of the env); its
        ``n_cars`` must be ``len(car_nodes)``.
    axis : travel axis of the FE model. direction : +1 if the train travels towards +axis.
    start_time : first contact, s (default the first nodout sample); earlier samples dropped.

    Returns
    -------
    :class:`CrashResult` with ``model="reference"`` (the FE run stands in for the reference
    model), bodies ``lead, car2, …``, zones ``wall, interface_1, …`` (``crush``: the
    centre-of-mass feature less :func:`carbody_shortening`), no energies.
    """
    if axis not in AXES:
        raise ValueError(f"axis must be one of {AXES}, got {axis!r}")
    if direction not in (1, -1, 1.0, -1.0):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    sc = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    car_nodes, interface_contacts = _check_fe_ids(nodes, car_nodes, interface_contacts, sc)
    used = [k for k in contacts if k[1] in (wall_contact, *interface_contacts)]
    keep = _fe_window(nodes[car_nodes[0]].t, [contacts[k].t for k in used], start_time)
    tk = nodes[car_nodes[0]].t[keep]
    x = np.column_stack([nodes[n][f"{axis}_disp"][keep] for n in car_nodes]) * direction
    x -= x[0]
    v = np.column_stack([nodes[n][f"{axis}_vel"][keep] for n in car_nodes]) * direction
    a = np.column_stack([nodes[n][f"{axis}_accl"][keep] for n in car_nodes]) * direction
    force = np.column_stack(
        [_contact_force(contacts, c, axis, tk) for c in (wall_contact, *interface_contacts)]
    )
    short = carbody_shortening(sc, tk, force)
    # crush between the car ends: the centre-of-mass distances less the carbodies' shortening
    ends = [x[:, 0] - short[:, 0]]
    for k in range(1, x.shape[1]):
        ends.append(x[:, k] - x[:, k - 1] - short[:, 2 * k - 1] - short[:, 2 * k])
    crush = np.column_stack(ends)
    n_zones = force.shape[1]
    return CrashResult(
        t=tk - tk[0],
        x=x,
        v=v,
        a=a,
        body_names=["lead"] + [f"car{k + 1}" for k in range(1, len(car_nodes))],
        zone_names=["wall"] + [f"interface_{k}" for k in range(1, n_zones)],
        crush=crush,
        force=force,
        permanent_set=np.zeros_like(force),
        energy={},
        initial_kinetic_energy=float(0.5 * np.sum(sc.car_masses * v[0] ** 2)),
        dt=float(np.min(np.diff(tk))),
        wall_time=0.0,
        scenario=sc,
        model="reference",
        extra={"source": "FE output"},
    )


def crash_surrogate_from_fe(
    nodout: str | Path,
    rcforc: str | Path,
    *,
    units: str,
    car_nodes: Sequence[int],
    wall_contact: int,
    interface_contacts: Sequence[int],
    scenario: CrashScenario | str | Path,
    fit: CrashFitOptions | None = None,
    axis: str = "x",
    direction: float = 1.0,
    start_time: float | None = None,
) -> CrashSurrogate:
    """Read ``nodout`` and ``rcforc`` (unit set ``units``) and fit the crash elements.

    Arguments as :func:`crash_result_from_fe`; ``fit``: the arguments of
    :func:`build_crash_surrogate` (:class:`CrashFitOptions`, ``None``: its defaults).
    """
    t0 = time.perf_counter()
    result = crash_result_from_fe(
        io.read_nodout(nodout, nodes=car_nodes, units=units),
        io.read_rcforc(rcforc, units=units),
        car_nodes=car_nodes,
        wall_contact=wall_contact,
        interface_contacts=interface_contacts,
        scenario=scenario,
        axis=axis,
        direction=direction,
        start_time=start_time,
    )
    f = CrashFitOptions() if fit is None else fit
    out = build_crash_surrogate(
        result, f.variant, f.seed, f.max_degree, f.degrees, f.nodes_per_car, f.knots
    )
    out.origin = f"FE: {nodout}, {rcforc} ({units})"
    out.build_time = time.perf_counter() - t0
    return out


# ------------------------------------------------------------------------------ JSON files
def _model_document(model: Any) -> dict[str, Any]:
    if isinstance(model, PiecewiseEnvelope):
        return model.to_document()
    return io.model_to_document(model, inputs=["u"], output="f", units={"u": "m", "f": "N"})


def _model_from_document(doc: Any, where: str) -> Any:
    if isinstance(doc, Mapping) and doc.get("kind") == "piecewise":
        return PiecewiseEnvelope.from_document(doc, where)
    return io.model_from_document(doc, where)


def _element_document(el: CrashElement) -> dict[str, Any]:
    return {
        "name": el.name,
        "variant": el.variant,
        "loading": _model_document(el.loading),
        "unloading": None if el.unloading is None else _model_document(el.unloading),
        "unloading_stiffness": el.unloading_stiffness,
        "tension_stiffness": el.tension_stiffness,
        "slack": el.slack,
        "unilateral": el.unilateral,
        "force_range": {k: list(v) for k, v in el.force_range.items()},
        "selection": {
            k: {"method": s.method, "best": s.best, "table": s.table}
            for k, s in el.selection.items()
        },
        "n_samples": el.n_samples,
        "zone_unloading_stiffness": el.zone_unloading_stiffness,
    }


def save_crash_surrogate(
    surrogate: CrashSurrogate,
    path: str | Path,
    overwrite: bool = False,
    metadata: Mapping[str, Any] | None = None,
) -> Path:
    """Write the elements as JSON (format ``railgym-crash-surrogate``, schema 1);
    ``metadata`` (JSON values) is stored under ``"metadata"`` and ignored when loading."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True to replace it")
    doc = {
        "metadata": dict(metadata or {}),
        "format": FORMAT,
        "schema_version": SCHEMA_VERSION,
        "variant": surrogate.variant,
        "source": surrogate.source,
        "origin": surrogate.origin,
        "nodes_per_car": surrogate.nodes_per_car,
        "build_time_s": surrogate.build_time,
        "elements": {k: _element_document(e) for k, e in surrogate.elements.items()},
    }
    io.write_atomic(path, json.dumps(jsonable(doc), indent=1) + "\n")
    return path


def _field(d: Mapping[str, Any], key: str, where: str) -> Any:
    if not isinstance(d, Mapping) or key not in d:
        raise ValueError(f"{where}: missing field {key!r}")
    return d[key]


def _number(d: Mapping[str, Any], key: str, where: str) -> float:
    v = _field(d, key, where)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ValueError(f"{where}: field {key!r} must be a finite number, got {v!r}")
    return float(v)


def _element_from_document(d: Any, where: str) -> CrashElement:
    loading = _model_from_document(_field(d, "loading", where), f"{where}.loading")
    un = _field(d, "unloading", where)
    unloading = None if un is None else io.model_from_document(un, f"{where}.unloading")
    rng = _field(d, "force_range", where)
    sel = _field(d, "selection", where)
    return CrashElement(
        name=str(_field(d, "name", where)),
        variant=str(_field(d, "variant", where)),
        loading=loading,
        unloading=unloading,
        unloading_stiffness=_number(d, "unloading_stiffness", where),
        tension_stiffness=_number(d, "tension_stiffness", where),
        slack=_number(d, "slack", where),
        unilateral=bool(_field(d, "unilateral", where)),
        force_range={k: (float(a), float(b)) for k, (a, b) in rng.items()},
        selection={k: SelectionResult(s["method"], s["table"], s["best"]) for k, s in sel.items()},
        n_samples={k: int(v) for k, v in _field(d, "n_samples", where).items()},
        zone_unloading_stiffness=(
            None
            if d.get("zone_unloading_stiffness") is None
            else _number(d, "zone_unloading_stiffness", where)
        ),
    )


def load_crash_surrogate(path: str | Path) -> CrashSurrogate:
    """Read elements written by :func:`save_crash_surrogate`; clear errors for bad files."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from exc
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ValueError(f"{path}: field 'format' must be {FORMAT!r}")
    if doc.get("schema_version") != SCHEMA_VERSION:
        raise ValueError(f"{path}: schema_version {doc.get('schema_version')!r} is not supported")
    elements = _field(doc, "elements", str(path))
    for need in ("wall", "interface"):
        if need not in elements:
            raise ValueError(f"{path}: field 'elements' has no {need!r} element")
    try:
        els = {k: _element_from_document(v, f"{path}: elements.{k}") for k, v in elements.items()}
    except (KeyError, TypeError) as exc:
        raise ValueError(f"{path}: malformed element ({exc!r})") from exc
    nodes = doc.get("nodes_per_car", 1)
    if isinstance(nodes, bool) or not isinstance(nodes, int) or not 1 <= nodes <= MAX_NODES:
        raise ValueError(f"{path}: field 'nodes_per_car' must be an integer in [1, {MAX_NODES}]")
    return CrashSurrogate(
        variant=str(_field(doc, "variant", str(path))),
        elements=els,
        source=str(doc.get("source", path)),
        build_time=float(doc.get("build_time_s", 0.0)),
        origin=str(doc.get("origin", "reference model")),
        nodes_per_car=nodes,
    )


# ------------------------------------------------------------------------------ FMU export
def export_crash_element_fmu(
    element: CrashElement, path: str | Path, *, overwrite: bool = False, binary: bool = True
) -> Path:
    """Co-simulation FMU of one crash element with its memory (permanent set), by
    :func:`surrogates.fmi.hysteretic.export_hysteretic_fmu`: inputs ``u`` (m) and ``rate``
    (m/s), outputs ``f`` (N) and ``permanent_set`` (m), the law of ``element``'s variant."""
    from surrogates.fmi.hysteretic import HystereticLaw, export_hysteretic_fmu

    if not isinstance(element, CrashElement):
        raise val.FieldTypeError(
            "element",
            "must be a CrashElement, one element of a CrashSurrogate (e.g. "
            f"crash_surrogate_from_fe(...).elements['wall']), got {type(element).__name__}",
        )
    if isinstance(element.loading, PiecewiseEnvelope):
        raise ValueError(
            f"element {element.name!r} has a piecewise envelope (one LPR per crush stage); the "
            "FMU holds a single LPR: fit the element without knots to export it"
        )
    law = HystereticLaw(
        variant=element.variant,
        unilateral=element.unilateral,
        unloading_stiffness=element.unloading_stiffness,
        tension_stiffness=element.tension_stiffness,
        slack=element.slack,
        loading_range=element.force_range["loading"],
        unloading_range=element.force_range.get("unloading"),
    )
    return export_hysteretic_fmu(
        path,
        element.loading,
        law,
        element.unloading,
        name=f"{element.name} element",
        binary=binary,
        overwrite=overwrite,
    )


if __name__ == "__main__":
    from surrogates.cli_flags import moved_command

    raise SystemExit(moved_command("railgym.vehicles.crash.fe", "railgym crash-fe"))
