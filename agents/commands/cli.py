"""The ``railgym`` command: every entry point of railgym is one of its subcommands.

- ``railgym demo [-o DIR]``: the main job of the quickstart — build the surrogate element
  from the reference model (paper stages 1–3), run one episode each on the surrogate and the
  reference backend, passive and with skyhook, on the same track (stage 4), print the paper's
  indices, the speed of the surrogate against the reference FMU in the loop and the internal
  reference measured in the same run (:mod:`agents.evaluation.speed`), and write the plots of
  :data:`DEMO_FILES` (a re-run replaces them).
- ``railgym paper [--quick] [-o DIR]``: the paper's tables and figures on our models
  (:func:`railgym.report.make_report`), written as :data:`railgym.report.REPORT_FILES` (a
  re-run replaces them).
- ``railgym evaluate POLICY ...``: comfort indices of controllers or saved policies on the
  vertical env and the whole vehicle (``--env vehicle``), crash indices (``--env crash``, the
  held-out impact envelope with ``--envelope``); ``--workers N`` / ``--address ADDR`` run the
  cases in parallel (:mod:`agents.commands.evaluate`).
- ``railgym refine POLICY ...``: refine the surrogate element for a policy
  (:mod:`agents.commands.refine`).
- ``railgym export-reference-fmu`` / ``export-policy``: FMUs for FMI tools
  (:mod:`agents.commands.export_fmu`).
- the module commands of :data:`MODULE_COMMANDS` (``railgym train``:
  :mod:`agents.commands.train`, ...): the module's own parser reads the rest of the command
  line.

One vocabulary (:mod:`surrogates.cli_flags`, ``docs/cli.md``): ``-o/--out`` is what a command
writes, ``--overwrite`` lets it replace what is there, ``--seed`` seeds what it draws, every
command takes ``--debug`` and ``--quiet`` (no progress bars or notes; bars are drawn on stderr
only when it is a terminal). Arguments and output folders are checked before any work; an
output folder is reused when it holds only the command's own files (``demo``, ``paper``),
one holding other files needs ``--overwrite``. A user error (bad value, such a folder
without ``--overwrite``, unreadable file) is one line on stderr and exit status 2, another
failure one line and status 1; ``--debug`` shows the traceback instead. A warning (e.g. of
``--trust``) is one line ``railgym CMD: warning: …`` on stderr, without Python source.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents._extras import MissingExtraError, report_missing
from agents.commands.flags import (
    add_parallel_arguments,
    check_parallel,
    error_status,
    one_line_warnings,
)
from agents.controllers.classical import Passive, Skyhook
from agents.evaluation.speed import backend_speeds, format_speeds
from railgym import _checks as val
from railgym.comfort import sperling_wz, weighted_rms
from railgym.envs.vertical.env import VerticalSuspensionEnv
from railgym.progress import quiet, stages
from railgym.report import REPORT_FILES, make_report
from railgym.report.output import prepare_output_dir
from railgym.vehicles.collect import build_vertical_surrogate
from surrogates.cli_flags import (
    Parser,
    RawHelpFormatter,
    add_common,
    add_out,
    add_seed,
)
from surrogates.metrics import average_absolute_error


def run_episode(env: VerticalSuspensionEnv, controller: Any, seed: int) -> dict[str, Any]:
    """One episode; returns the carbody record (x2, v2, a2 at control rate) and the totals."""
    obs, info = env.reset(seed=seed)
    rec: dict[str, list[float]] = {"t": [], "x2": [], "v2": [], "a2": [], "force": []}
    t0 = time.perf_counter()
    while True:
        action, _ = controller.predict(obs, deterministic=True)
        obs, _, term, trunc, info = env.step(action)
        state = env.state
        values = (info["time"], state[2], state[3], info["carbody_acc"], info["actuator_force"])
        for key, value in zip(rec, values, strict=True):
            rec[key].append(float(value))
        if term or trunc:
            break
    out: dict[str, Any] = {k: np.asarray(v) for k, v in rec.items()}
    out.update(wall_s=time.perf_counter() - t0, info=info)
    return out


def _indices(run: dict[str, Any], fs: float) -> dict[str, float]:
    return {
        "rms_acc": float(np.sqrt(np.mean(run["a2"] ** 2))),
        "a_w": weighted_rms(run["a2"], fs, discard=2.0, lowpass=False),
        "wz": sperling_wz(run["a2"], fs),
        "contacts": run["info"]["bump_stop_contacts"],
        "ood": run["info"]["out_of_domain"],
        "wall_s": run["wall_s"],
    }


#: interleaved rounds of the speed table of ``railgym demo`` (:mod:`agents.evaluation.speed`)
SPEED_ROUNDS = 3

#: the files ``railgym demo`` writes into its folder, with what each shows
DEMO_FILES = {
    "samples_and_oob.png": "training samples and out-of-bag prediction (paper figs. 7, 8)",
    "carbody_acceleration.png": "carbody acceleration, surrogate vs reference and their "
    "difference (paper fig. 9)",
}


def demo(out: Path, seed: int = 0, overwrite: bool = False) -> int:
    """Build the surrogate, compare surrogate and reference under skyhook, write the plots of
    :data:`DEMO_FILES` into ``out``. A folder holding only these files is reused (a re-run
    replaces them); one holding other files only with ``overwrite``."""
    seed = val.integer(seed, "seed", min=0)
    out = prepare_output_dir(out, overwrite, own=DEMO_FILES)
    print("1-3. collect (dynamic reference, FRA class 5, 144 km/h, 20 s at 50 Hz), sample, fit")
    model, report, data = build_vertical_surrogate(
        m=101, seed=seed, track_seed=seed, progress=stages()
    )
    print(report.format("N").split("\n   candidate")[0])
    runs: dict[tuple[str, str], dict[str, Any]] = {}
    for backend in ("surrogate", "reference"):
        surrogate = model if backend == "surrogate" else None  # the others take none
        env = VerticalSuspensionEnv(backend=backend, surrogate=surrogate)
        env.reset(seed=seed)
        env.step(np.zeros(1, np.float32))  # compile (or load) the kernel outside the timing
        for name, ctrl in (("passive", Passive(env)), ("skyhook", Skyhook(env))):
            runs[backend, name] = run_episode(env, ctrl, seed)
    fs = 1.0 / env.cfg.control_dt
    print(f"\n4. one 20 s episode per model and controller on the same track (seed {seed})")
    head = f"{'model':<10} {'controller':<10} {'RMS ẍ2 m/s²':>12} {'a_w Wk m/s²':>12} "
    print(head + f"{'Sperling Wz':>11} {'contacts':>8} {'out-dom':>8} {'wall s':>7}")
    for (backend, name), run in runs.items():
        ix = _indices(run, fs)
        print(
            f"{backend:<10} {name:<10} {ix['rms_acc']:12.3f} {ix['a_w']:12.3f} {ix['wz']:11.2f} "
            f"{ix['contacts']:8d} {ix['ood']:8d} {ix['wall_s']:7.3f}"
        )
    print("wall s: one single-env episode, Python shell included; the models' cost is in 5.")
    print("\nsurrogate vs reference, eq. 9 average absolute error of the carbody (paper table 5)")
    print(f"{'controller':<9} {'disp. (m)':>10} {'vel. (m/s)':>11} {'acc. (m/s²)':>12}")
    for name in ("passive", "skyhook"):
        s, r = runs["surrogate", name], runs["reference", name]
        errs = [average_absolute_error(s[k], r[k]) for k in ("x2", "v2", "a2")]
        print(f"{name:<9} {errs[0]:10.3g} {errs[1]:11.3g} {errs[2]:12.3g}")
    print(
        "paper (LPR, M = 101, Simpack source; not directly comparable): "
        "2.44e-06 m, 2.38e-05 m/s, 5.67e-04 m/s²"
    )
    print("\n5. speed: the surrogate element against the high-fidelity model it replaces")
    rows, skipped = backend_speeds(model, rounds=SPEED_ROUNDS)
    print(format_speeds(rows, skipped, SPEED_ROUNDS))
    _plots(out, model, report, data, runs)
    print(f"\nplots written to {out}/")
    return 0


def _plots(out: Path, model: Any, report: Any, data: dict, runs: dict) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install 'railgym[plot]'): no plots")
        return
    U, V = data["U"], data["V"]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    ax[0].plot(U[:, 0] * 1e3, U[:, 1], ".", ms=3, color="tab:blue", label=f"all data ({len(U)})")
    tr = report.train_idx
    ax[0].plot(U[tr, 0] * 1e3, U[tr, 1], "o", ms=5, color="tab:red", label=f"training ({len(tr)})")
    ax[0].set(xlabel="x1 − x2 (mm)", ylabel="ẋ1 − ẋ2 (m/s)", title="Samples (paper fig. 7)")
    ax[0].legend()
    oob = report.oob_idx
    ax[1].plot(V[oob] / 1e3, model.predict(U[oob]) / 1e3, ".", ms=3)
    lim = [V.min() / 1e3, V.max() / 1e3]
    ax[1].plot(lim, lim, "k-", lw=0.8)
    ax[1].set(
        xlabel="reference m2·ẍ2 (kN)",
        ylabel="surrogate (kN)",
        title=f"Out-of-bag prediction, rel. RMS {report.oob_nrms:.3f} (fig. 8)",
    )
    fig.tight_layout()
    fig.savefig(out / "samples_and_oob.png", dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(
        4, 1, figsize=(11, 8), sharex=True, gridspec_kw={"height_ratios": [3, 1, 3, 1]}
    )
    for i, name in enumerate(("passive", "skyhook")):
        s, r = runs["surrogate", name], runs["reference", name]
        top, diff = ax[2 * i], ax[2 * i + 1]
        top.plot(r["t"], r["a2"], lw=0.8, label="reference")
        top.plot(s["t"], s["a2"], lw=0.8, ls="--", label="surrogate")
        top.set(ylabel="ẍ2 (m/s²)", title=f"Carbody acceleration, {name} (paper fig. 9)")
        top.legend(loc="upper right")
        d = s["a2"] - r["a2"]  # the same control steps
        rms = float(np.sqrt(np.mean(d**2)))
        diff.plot(r["t"], d, lw=0.7, color="tab:red", label=f"RMS {rms:.3g} m/s²")
        diff.axhline(0.0, color="k", lw=0.5)
        diff.set(ylabel="Δẍ2 (m/s²)")
        diff.legend(loc="upper right", fontsize=8)
    ax[3].set_xlabel("t (s);  Δ: surrogate − reference")
    fig.tight_layout()
    fig.savefig(out / "carbody_acceleration.png", dpi=110)
    plt.close(fig)


def paper(args: argparse.Namespace) -> int:
    """``railgym paper``: write the report, print where and the table 3 headline."""
    check_parallel(args)
    result = make_report(
        args.out,
        quick=args.quick,
        seed=args.seed,
        overwrite=args.overwrite,
        workers=args.workers,
        address=args.address,
    )
    t3 = result["table3"]
    print(
        f"report written to {Path(args.out) / 'report.md'} with {len(result['figures'])} "
        f"figures in {result['elapsed_s']:.1f} s"
    )
    print(
        f"table 3 (M = {t3['m']}): OOB relative RMS LPR {t3['lpr']['oob_nrms']:.3g}, "
        f"Kriging {t3['kriging']['oob_nrms']:.3g}"
    )
    return 0


def _out_arguments(parser: argparse.ArgumentParser, default: str, what: str, own: str) -> None:
    """``-o/--out`` (a folder, ``default``; ``what`` is written there, a folder holding only
    ``own`` is reused), ``--overwrite`` and ``--seed``."""
    add_out(
        parser,
        f"folder for {what} (created, or {own})",
        default=Path(default),
        overwrite="write into an -o/--out folder that holds other files too (they are kept, "
        "the command's own files replaced)",
    )
    add_seed(parser, "seed of the training track, sampling and folds")


def _version() -> str:
    """The installed distribution's version (``unknown`` when run from a bare source tree)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("railgym")
    except PackageNotFoundError:
        return "unknown"


#: subcommands with a module of their own: name → (module, its line in ``railgym --help``);
#: the module's ``main(argv)`` runs it, its ``build_parser()`` (or that of
#: :data:`PARSER_MODULES`) has the arguments
MODULE_COMMANDS = {
    "train": ("agents.commands.train", "train an SB3 agent from a config"),
    "train-rllib": ("agents.training.train_rllib", "train an RLlib PPO agent from a config"),
    "benchmark": (
        "agents.commands.benchmark",
        "seeds, held-out evaluation, curve and table of a config",
    ),
    "pretrained": ("agents.commands.pretrained", "ship a benchmarked policy as a pretrained one"),
    "collect": ("agents.commands.collect", "collect and build a vertical element"),
    "collect-vehicle": ("agents.commands.collect_vehicle", "build the whole-vehicle element"),
    "combine": (
        "agents.commands.combine",
        "an element of a bench-tested damper with the vehicle file's springs and bump stops",
    ),
    "validate": (
        "agents.commands.validate",
        "surrogate against reference or FMU, per class",
    ),
    "validity": ("agents.commands.validity", "the validity flags against the surrogate's error"),
    "crash-report": ("agents.commands.crash_report", "crash baseline and surrogate-error tables"),
    "crash-limits": (
        "agents.commands.crash_limits",
        "ceilings of crash absorber control per range",
    ),
    "crash-fe": ("agents.commands.crash_fe", "crash elements from LS-DYNA nodout/rcforc"),
    "crash-elements": ("agents.commands.crash_elements", "fit a scenario's crash elements"),
    "damper-element": ("agents.commands.damper_element", "the element of a controllable damper"),
    "env-tables": ("agents.commands.env_tables", "rewrite the argument tables of docs/envs"),
    "surrogates": ("surrogates.cli", "the surrogates command: build, export-fmu"),
    "leaderboard": ("agents.commands.leaderboard", "benchmark tasks: scores, bounds, entries"),
    "semi-active-bound": (
        "agents.commands.semi_active_bound",
        "best open-loop damper commands per track against the semi-active baselines",
    ),
}

#: the module with the parser of a module command whose own module needs an extra
PARSER_MODULES = {"train-rllib": "agents.commands.train_rllib"}


def module_parser(name: str) -> argparse.ArgumentParser:
    """The full parser of the module command ``name`` (:data:`MODULE_COMMANDS`)."""
    import importlib

    module = PARSER_MODULES.get(name, MODULE_COMMANDS[name][0])
    parser: argparse.ArgumentParser = importlib.import_module(module).build_parser()
    return parser


def build_parser() -> argparse.ArgumentParser:
    """The ``railgym`` argument parser (a module command's own arguments: :func:`module_parser`)."""
    common = argparse.ArgumentParser(add_help=False)
    add_common(common)
    parser = Parser(prog="railgym", description=__doc__.split("\n\n")[0])
    parser.add_argument("--version", action="version", version=f"railgym {_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    written = "\n".join(f"  {name}: {what}" for name, what in DEMO_FILES.items())
    d = sub.add_parser(
        "demo",
        parents=[common],
        help="build a surrogate, run surrogate vs reference, plot",
        description="Build the surrogate element from the reference model, run one episode\n"
        "each on the surrogate and the reference, passive and with skyhook, print the\n"
        "paper's indices and the env-steps/s of the surrogate, the reference and the\n"
        "reference FMU measured in the same run, and write the plots.",
        epilog=f"writes into -o/--out:\n{written}\nA folder that holds only these files is "
        "reused and they are replaced, so the command\ncan be run again; a folder with other "
        "files needs --overwrite.",
        formatter_class=RawHelpFormatter,
    )
    _out_arguments(d, "railgym-demo", "the plots", "one holding only these plots")
    report_files = "\n".join(f"  {name}" for name in REPORT_FILES)
    p = sub.add_parser(
        "paper",
        parents=[common],
        help="the paper's tables and figures",
        description="The paper's tables and figures on railgym's models: report.md and the "
        "figures.",
        epilog=f"writes into -o/--out:\n{report_files}\nA folder that holds only these files "
        "is reused and they are replaced, so the command\ncan be run again; a folder with "
        "other files needs --overwrite.",
        formatter_class=RawHelpFormatter,
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="reduced sizes (CI): M = 51, 101; 5 s runs; one crash variant",
    )
    _out_arguments(p, "railgym-paper", "report.md and the figures", "one holding only these files")
    add_parallel_arguments(p, "", "the validation matrix", "the report does")
    from agents.commands import evaluate, export_fmu, refine

    for name, add, what, description in (
        ("evaluate", evaluate.add_arguments, "comfort indices of policies", EVALUATE),
        ("refine", refine.add_arguments, "refine the element for a policy", REFINE),
        (
            "export-reference-fmu",
            export_fmu.add_reference_arguments,
            "the reference model as an FMU",
            export_fmu.REFERENCE_DESCRIPTION,
        ),
        (
            "export-policy",
            export_fmu.add_policy_arguments,
            "a trained policy as an FMU",
            export_fmu.POLICY_DESCRIPTION,
        ),
    ):
        add(sub.add_parser(name, parents=[common], help=what, description=description))
    for name, (module, what) in MODULE_COMMANDS.items():
        sub.add_parser(
            name,
            help=what if module.startswith("agents.") else f"{what} (python -m {module})",
            add_help=False,
        )
    return parser


#: description of ``railgym evaluate --help``
EVALUATE = (
    "Comfort indices of controllers and saved policies (vertical env, whole vehicle with "
    "--env vehicle) or crash indices (--env crash; the held-out impact envelope with "
    "--envelope), beside the passive (and skyhook) rows; --gap runs each on the surrogate "
    "and on --backend and prints their relative gap. Prints one table."
)
#: description of ``railgym refine --help``
REFINE = (
    "Refine a surrogate element for a policy: per round, run the policy on the reference, add "
    "the samples where the element is worst and refit; print the held-out error per round and "
    "write the refined element to -o/--out (docs/refine.md)."
)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``railgym`` command; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    # a command runs the env version its config or policy names: gymnasium's notice that a
    # newer version is registered is for a user's own gym.make
    warnings.filterwarnings(
        "ignore", r".*environment railgym/\S+ is out of date", DeprecationWarning
    )
    if argv and argv[0] in MODULE_COMMANDS:  # the module's own parser reads the rest
        import importlib

        try:
            module = importlib.import_module(MODULE_COMMANDS[argv[0]][0])
        except MissingExtraError as err:
            if argv[0] in PARSER_MODULES and {"-h", "--help"} & set(argv[1:]):
                module_parser(argv[0]).parse_args(["--help"])  # its help needs no extra
            return report_missing(err, f"railgym {argv[0]}", argv[0])
        return int(module.main(argv[1:]))
    args = build_parser().parse_args(argv)
    from agents.commands import evaluate, export_fmu, refine

    command = {
        "export-reference-fmu": export_fmu.run_reference,
        "export-policy": export_fmu.run_policy,
        "demo": lambda a: demo(a.out, a.seed, a.overwrite),
        "paper": paper,
        "evaluate": evaluate.run,
        "refine": refine.run,
    }[args.command]
    try:
        with quiet(args.quiet), one_line_warnings(f"railgym {args.command}"):
            return command(args)
    except MissingExtraError as err:
        if args.debug:
            raise
        return report_missing(err, f"railgym {args.command}", args.command)
    except Exception as err:
        return error_status(f"railgym {args.command}", err, args.debug)


if __name__ == "__main__":
    sys.exit(main())
