"""``railgym export-reference-fmu`` and ``railgym export-policy``: FMUs for FMI tools.

- ``railgym export-reference-fmu --env vertical -o OUT.fmu [--fmu-kind both|cs|me]``: the
  built-in reference model as an FMI 2.0 FMU and its mapping file ``OUT.yaml``
  (:func:`railgym.fmu.reference.export_reference_fmu`), so that ``backend="fmu"`` runs it.
- ``railgym export-policy POLICY -o OUT.fmu [--onnx OUT.onnx]``: a trained SB3 policy (a zip
  or a pretrained name such as ``ppo-vertical``; plain or residual) as a standalone
  co-simulation FMU (:mod:`agents.policies.policy_fmu`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from surrogates.cli_flags import add_out

#: description of ``railgym export-reference-fmu --help``
REFERENCE_DESCRIPTION = (
    "Write railgym's reference model as an FMI 2.0 FMU and its mapping file (the .fmu with "
    "the suffix .yaml), so that --backend fmu runs it."
)
#: description of ``railgym export-policy --help``
POLICY_DESCRIPTION = (
    "Write a trained SB3 policy (plain or residual, a zip or a pretrained name) as a "
    "standalone co-simulation FMU, and optionally as ONNX."
)


def add_fmu_kind(parser: argparse.ArgumentParser) -> None:
    """``--fmu-kind``: the FMI interfaces an exported FMU has."""
    parser.add_argument(
        "--fmu-kind",
        choices=("both", "cs", "me"),
        default="both",
        help="FMI interfaces: co-simulation, model exchange or both",
    )


def add_reference_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``railgym export-reference-fmu``."""
    parser.add_argument(
        "--env", choices=("vertical", "vehicle"), default="vertical", help="the env"
    )
    add_out(
        parser,
        "the .fmu to write (its mapping file beside it)",
        required=True,
        overwrite="replace existing files",
    )
    add_fmu_kind(parser)
    parser.add_argument("--vehicle", default="manchester", help="vehicle name or YAML path")


def run_reference(args: argparse.Namespace) -> int:
    """Write the reference FMU and its mapping file; print both paths."""
    from railgym.fmu.reference import export_reference_fmu

    if args.out.suffix != ".fmu":
        raise ValueError(f"-o must name a .fmu file, got {str(args.out)!r}")
    fmu, mapping = export_reference_fmu(
        args.out, args.env, args.fmu_kind, vehicle=args.vehicle, overwrite=args.overwrite
    )
    print(f"wrote {fmu} and its mapping file {mapping}")
    return 0


def add_policy_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``railgym export-policy``."""
    parser.add_argument(
        "policy",
        help="a pretrained policy name (ppo-vertical, ppo-vehicle, ppo-preview) or a policy .zip "
        "(config.yaml beside it); a residual policy brings its classical controller",
    )
    add_out(
        parser,
        "the .fmu to write",
        required=True,
        overwrite="replace existing files",
    )
    parser.add_argument("--onnx", type=Path, help="also write the policy as this .onnx")
    parser.add_argument(
        "--trust",
        action="store_true",
        help="export a zip that its manifest.json does not list (only weights are read)",
    )


def run_policy(args: argparse.Namespace) -> int:
    """Write the controller FMU (and ONNX); print the paths."""
    from agents.policies.policy_fmu import export_policy

    fmu, onnx = export_policy(
        args.policy, args.out, args.onnx, trust=args.trust, overwrite=args.overwrite
    )
    print(f"wrote {fmu}" + (f" and {onnx}" if onnx else ""))
    return 0
