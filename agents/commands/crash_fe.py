"""``railgym crash-fe``: crash elements fitted to an LS-DYNA run's ASCII nodout and rcforc
files (:func:`railgym.vehicles.crash.fe.crash_surrogate_from_fe`), written as JSON and, with
``--fmu-dir``, as FMUs."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from railgym.vehicles.crash.fe import (
    AXES,
    crash_surrogate_from_fe,
    export_crash_element_fmu,
    save_crash_surrogate,
)
from railgym.vehicles.crash.surrogate import MAX_NODES_PER_CAR as MAX_NODES
from railgym.vehicles.crash.surrogate import CrashFitOptions
from surrogates.checks import bounded_int
from surrogates.cli_flags import (
    Parser,
    add_common,
    add_out,
    add_seed,
    error_status,
)


def build_parser() -> argparse.ArgumentParser:
    """Arguments of ``railgym crash-fe``."""
    p = Parser(
        prog="railgym crash-fe",
        description="Crash elements (wall and interface force laws) fitted to an LS-DYNA "
        "run's ASCII nodout and rcforc files (docs/data.md).",
    )
    p.add_argument("--nodout", required=True, help="LS-DYNA ASCII nodout file")
    p.add_argument("--rcforc", required=True, help="LS-DYNA ASCII rcforc file")
    p.add_argument(
        "--unit-system", required=True, help="unit set of the FE model, e.g. mm-ms-kg-kN"
    )
    p.add_argument("--car-nodes", type=int, nargs="+", required=True, help="node per car")
    p.add_argument("--wall-contact", type=int, required=True, help="wall contact id")
    p.add_argument(
        "--interface-contacts", type=int, nargs="+", required=True, help="contact id per interface"
    )
    p.add_argument(
        "--scenario",
        required=True,
        help="scenario of the FE model (name or YAML): its cars (masses, carbodies, n_cars: one "
        "--car-nodes node each) and zones",
    )
    p.add_argument(
        "--nodes-per-car",
        type=bounded_int(1, MAX_NODES),
        default=1,
        help=f"masses per car of the surrogate the elements are for (1..{MAX_NODES}; 1: rigid "
        "cars, the elements then hold the carbodies' elasticity too)",
    )
    p.add_argument(
        "--variant", choices=["hysteretic", "paper"], default="hysteretic", help="element form"
    )
    p.add_argument("--axis", choices=list(AXES), default="x", help="the impact axis")
    p.add_argument(
        "--direction",
        type=float,
        choices=[1.0, -1.0],
        default=1.0,
        help="sign of the impact along --axis",
    )
    p.add_argument("--start-time", type=float, default=None, help="first contact, s")
    add_seed(p, "seed of the fit's sampling")
    add_out(p, "the elements JSON to write", required=True, type=str)
    p.add_argument("--fmu-dir", help="also export each element as <name>.fmu (co-simulation)")
    add_common(p)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """``railgym crash-fe``: crash elements from LS-DYNA nodout/rcforc."""
    p = build_parser()
    args = p.parse_args(argv)
    try:
        return _from_fe(args)
    except Exception as err:
        return error_status(p.prog, err, args.debug)


def _from_fe(args: argparse.Namespace) -> int:
    """``railgym crash-fe`` after the parse: fit, write the elements (and their FMUs)."""
    if Path(args.out).exists() and not args.overwrite:
        raise ValueError(f"--out {args.out}: exists; pass --overwrite to replace it")
    sur = crash_surrogate_from_fe(
        args.nodout,
        args.rcforc,
        units=args.unit_system,
        car_nodes=args.car_nodes,
        wall_contact=args.wall_contact,
        interface_contacts=args.interface_contacts,
        scenario=args.scenario,
        fit=CrashFitOptions(variant=args.variant, seed=args.seed, nodes_per_car=args.nodes_per_car),
        axis=args.axis,
        direction=args.direction,
        start_time=args.start_time,
    )
    save_crash_surrogate(sur, args.out, overwrite=args.overwrite)
    if args.fmu_dir:
        for name, el in sur.elements.items():
            fmu = Path(args.fmu_dir) / f"{name}.fmu"
            try:
                export_crash_element_fmu(el, fmu, overwrite=args.overwrite)
            except RuntimeError as exc:
                raise ValueError(str(exc)) from None
            print(f"{name} element FMU written to {fmu}")
    for name, el in sur.elements.items():
        ku, own = el.unloading_stiffness, el.zone_unloading_stiffness
        zone = "" if own is None else f" (the zone's own, carbodies' shortening removed: {own:.4g})"
        print(f"{name}: degrees {el.degrees}, k_u {ku:.4g} N/m{zone}, samples {el.n_samples}")
    print(f"elements written to {args.out}")
    return 0
