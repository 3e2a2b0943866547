"""``railgym export-reference-fmu`` and ``railgym export-policy``: FMUs for FMI tools.

- ``railgym export-reference-fmu --env vertical -o OUT.fmu [--kind both|cs|me]``: the
  built-in reference model as an FMI 2.0 FMU and its mapping file ``OUT.yaml``
  (:func:`railgym.fmu.reference.export_reference_fmu`), so that ``backend="fmu"`` runs it.
- ``railgym export-policy POLICY -o OUT.fmu [--onnx OUT.onnx]``: a trained SB3 policy (a zip
  or a pretrained name such as ``ppo-vertical``; plain or residual) as a standalone
  co-simulation FMU (:mod:`agents.policy_fmu`).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_reference_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``railgym export-reference-fmu``."""
    parser.add_argument(
        "--env", choices=("vertical", "vehicle"), default="vertical", help="the env"
    )
    parser.add_argument("-o", "--output", type=Path, required=True, help="the .fmu to write")
    parser.add_argument(
        "--kind",
        choices=("both", "cs", "me"),
        default="both",
        help="co-simulation, model exchange or both (default)",
    )
    parser.add_argument("--vehicle", default="manchester", help="vehicle name or YAML path")
    parser.add_argument("--overwrite", action="store_true", help="replace existing files")


def run_reference(args: argparse.Namespace) -> int:
    """Write the reference FMU and its mapping file; print both paths."""
    from railgym.fmu.reference import export_reference_fmu

    if args.output.suffix != ".fmu":
        raise ValueError(f"-o must name a .fmu file, got {str(args.output)!r}")
    fmu, mapping = export_reference_fmu(
        args.output, args.env, args.kind, vehicle=args.vehicle, overwrite=args.overwrite
    )
    print(f"wrote {fmu} and its mapping file {mapping}")
    return 0


def add_policy_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``railgym export-policy``."""
    parser.add_argument(
        "policy",
        help="a pretrained policy name (ppo-vertical, ppo-vehicle) or a policy .zip "
        "(config.yaml beside it); a residual policy brings its classical controller",
    )
    parser.add_argument("-o", "--output", type=Path, required=True, help="the .fmu to write")
    parser.add_argument("--onnx", type=Path, help="also write the policy as this .onnx")
    parser.add_argument("--overwrite", action="store_true", help="replace existing files")
    parser.add_argument(
        "--trust",
        action="store_true",
        help="export a zip that its manifest.json does not list (only weights are read)",
    )


def run_policy(args: argparse.Namespace) -> int:
    """Write the controller FMU (and ONNX); print the paths."""
    from agents.policy_fmu import export_policy

    fmu, onnx = export_policy(
        args.policy, args.output, args.onnx, trust=args.trust, overwrite=args.overwrite
    )
    print(f"wrote {fmu}" + (f" and {onnx}" if onnx else ""))
    return 0
