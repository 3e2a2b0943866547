"""Bad command lines of ``railgym`` and ``railgym train``: each is refused before
any work with exit status 2, no traceback, and an error line that names the flag or file; in a
fresh process, every line on stderr (warnings too) is one ``railgym CMD: …`` line."""

from __future__ import annotations

import pickle
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
import yaml

from agents.commands.cli import main as railgym_main

pytest.importorskip("stable_baselines3")

from agents.commands.train import main as train_main  # noqa: E402

ENV_ID = "railgym/VerticalSuspension-v1"
TINY = {"algo": "ppo", "n_timesteps": 256, "n_envs": 1, "seed": 0}

ROWS = [
    # railgym paper / demo: output folder and seed
    ("railgym", "paper --quick --out {file}", "--out"),
    ("railgym", "paper --quick --out {nonempty}", "--out"),
    ("railgym", "paper --quick --out {file}/sub", "--out"),
    ("railgym", "paper --seed -1", "--seed"),
    ("railgym", "paper --seed abc", "--seed"),
    ("railgym", "paper --seed 1.5", "--seed"),
    ("railgym", "paper --quick=yes", "--quick"),
    ("railgym", "demo --out {file}", "--out"),
    ("railgym", "demo --out {nonempty}", "--out"),
    ("railgym", "demo --seed -3", "--seed"),
    # a folder holding the report's own files and another one: refused, naming the other
    ("railgym", "paper --quick --out {ownplus}", r"--out .*'keep\.txt'.*--overwrite"),
    ("railgym", "", "command"),
    ("railgym", "frobnicate", "command"),
    # railgym evaluate: numbers with their units and ranges
    ("railgym", "evaluate skyhook --episodes 0", "--episodes"),
    ("railgym", "evaluate skyhook --episodes -5", "--episodes"),
    ("railgym", "evaluate skyhook --episodes 1e9", "--episodes"),
    ("railgym", "evaluate skyhook --episodes 100000", "--episodes"),
    ("railgym", "evaluate skyhook --track-class 0", "--track-class"),
    ("railgym", "evaluate skyhook --track-class 7", "--track-class"),
    ("railgym", "evaluate skyhook --track-class x", "--track-class"),
    ("railgym", "evaluate passive --env crash --speed-kmh -40", "--speed-kmh: .*-40 km/h"),
    ("railgym", "evaluate passive --env crash --speed-kmh 0", "--speed-kmh"),
    ("railgym", "evaluate passive --env crash --speed-kmh nan", "--speed-kmh"),
    ("railgym", "evaluate passive --env crash --speed-kmh inf", "--speed-kmh"),
    ("railgym", "evaluate passive --env crash --speed-kmh 1e6", "--speed-kmh: .*km/h"),
    ("railgym", "evaluate passive --env crash --speed-kmh fast", "--speed-kmh"),
    ("railgym", "evaluate skyhook --seed -1", "--seed"),
    ("railgym", "evaluate skyhook --backend magic", "--backend"),
    ("railgym", "evaluate skyhook --env rail", "--env"),
    ("railgym", "evaluate passive --env crash --backend linear", "--backend"),
    # railgym evaluate: policies
    ("railgym", "evaluate", "policy"),
    ("railgym", "evaluate skyhook2", "policy must be one of"),
    ("railgym", "evaluate {missing}.zip", "policy must be one of"),
    ("railgym", "evaluate {noconfig}", "no manifest.json beside it"),
    ("railgym", "evaluate {noconfig} --trust", "not a zip file"),
    ("railgym", "evaluate {nomanifest}", "--trust"),
    ("railgym", "evaluate {zoobinary} --trust", r"config\.yml: not an rl-zoo3 .*: not UTF-8"),
    (
        "railgym",
        "evaluate passive --backend fmu --fmu-map {listmap}",
        r"list\.yaml: the mapping file must be a YAML mapping \(version:, env:, inputs:, "
        r"outputs:\), got a list",
    ),
    # railgym evaluate: the vehicle, crash envelope and parallel flags
    ("railgym", "evaluate skyhook --env vehicle --speed-kmh 0", "--speed-kmh"),
    ("railgym", "evaluate skyhook --env vehicle --duration 0", "--duration"),
    ("railgym", "evaluate skyhook --env vehicle --duration 1e9", "--duration"),
    ("railgym", "evaluate skyhook --env vehicle --duration nan", "--duration"),
    (
        "railgym",
        "evaluate groundhook --env vehicle",
        "groundhook is a controller of --actuator semi",
    ),
    ("railgym", "evaluate modal-skyhook", "policy must be one of"),
    ("railgym", "evaluate skyhook --speed-kmh 100", "--speed-kmh: only for --env vehicle"),
    ("railgym", "evaluate skyhook --duration 5", "--duration: only for"),
    ("railgym", "evaluate skyhook --envelope", "--envelope: only for --env crash"),
    ("railgym", "evaluate passive --env crash --envelope --backend surrogate", "--envelope"),
    ("railgym", "evaluate skyhook --env crash --envelope", "policy must be an existing"),
    ("railgym", "evaluate passive --env crash --workers 2", "--workers: only for"),
    ("railgym", "evaluate passive --env crash --address auto", "--address: only for"),
    ("railgym", "evaluate skyhook --workers 0", "--workers"),
    ("railgym", "evaluate skyhook --workers two", "--workers"),
    # railgym train
    ("train", "", "config"),
    ("train", "{missing}.yaml", "missing.yaml"),
    ("train", "{nonempty}", "nonempty"),
    ("train", "{cfg_n_envs}", "n_envs"),
    ("train", "{cfg_unknown}", "learning_rat"),
    ("train", "{cfg_broken}", r"broken\.yaml.*line 2"),
    ("train", "{cfg_list}", "mapping"),
    ("train", "{cfg} --timesteps 0", "--timesteps"),
    ("train", "{cfg} --timesteps abc", "--timesteps"),
    ("train", "{cfg} --seed -1", "--seed"),
    # one bound for every command's --seed: 0 .. 2**32 - 1
    ("train", "{cfg} --seed 4294967296", "--seed"),
    ("railgym", "paper --seed 4294967296", "--seed"),
    ("railgym", "evaluate skyhook --seed 4294967296", "--seed"),
    ("railgym", "refine skyhook --seed 4294967296", "--seed"),
    ("train", "{cfg} --out {nonempty}", "--out"),
    ("train", "{cfg} --out {file}", "--out"),
]


@pytest.fixture
def places(tmp_path, monkeypatch):
    """Files and folders the rows name; the working directory is ``tmp_path``."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("x")
    (tmp_path / "nonempty").mkdir()
    (tmp_path / "nonempty" / "keep.txt").write_text("keep")
    (tmp_path / "noconfig").mkdir()
    (tmp_path / "noconfig" / "model.zip").write_bytes(b"PK")
    (tmp_path / "nomanifest").mkdir()
    (tmp_path / "nomanifest" / "model.zip").write_bytes(b"PK")
    (tmp_path / "nomanifest" / "config.yaml").write_text(yaml.safe_dump({ENV_ID: TINY}))

    (tmp_path / "ownplus").mkdir()
    for name in ("report.md", "fig07_samples.png", "keep.txt"):
        (tmp_path / "ownplus" / name).write_text("x")
    (tmp_path / "list.yaml").write_text("- version: 1\n- env: vertical\n")
    zoo = tmp_path / "zoo" / "run_1"
    (zoo / "run").mkdir(parents=True)
    (zoo / "model.zip").write_bytes(b"PK")
    (zoo / "run" / "args.yml").write_text(f"algo: ppo\nenv: {ENV_ID}\n")
    (zoo / "run" / "config.yml").write_bytes(b"\xff\xfe\x00\x01binary")

    def config(name: str, block: object) -> str:
        path = tmp_path / f"{name}.yaml"
        path.write_text(yaml.safe_dump({ENV_ID: block}) if isinstance(block, dict) else block)
        return str(path)

    return {
        "file": str(tmp_path / "file"),
        "nonempty": str(tmp_path / "nonempty"),
        "missing": str(tmp_path / "missing"),
        "noconfig": str(tmp_path / "noconfig" / "model.zip"),
        "nomanifest": str(tmp_path / "nomanifest" / "model.zip"),
        "ownplus": str(tmp_path / "ownplus"),
        "listmap": str(tmp_path / "list.yaml"),
        "zoobinary": str(zoo / "model.zip"),
        "cfg": config("ok", TINY),
        "cfg_n_envs": config("n_envs", {**TINY, "n_envs": 0}),
        "cfg_unknown": config("unknown", {**TINY, "learning_rat": 0.1}),
        "cfg_broken": config("broken", "a: [1,\n"),
        "cfg_list": config("list", "- 1\n- 2\n"),
    }


@pytest.mark.parametrize(("prog", "argv", "names"), ROWS, ids=[f"{p} {a}" for p, a, _ in ROWS])
def test_bad_command_line_is_one_clear_error(places, capsys, prog, argv, names):
    args = argv.format(**places).split()
    main = railgym_main if prog == "railgym" else train_main
    try:
        code = main(args)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert "error:" in last
    assert re.search(names, last), last
    assert sorted(p.name for p in Path("nonempty").iterdir()) == ["keep.txt"]  # nothing written


FE = "--nodout n --rcforc r --unit-system mm-ms-kg-kN --car-nodes 1 --wall-contact 1 -o e.json"


@pytest.mark.parametrize(
    ("module", "argv", "flag"),
    [
        ("agents.commands.validate", "--duration 0", "--duration"),
        ("agents.commands.validate", "--duration 601", "--duration"),
        ("agents.commands.validate", "--track-class 7", "--track-class"),
        ("agents.commands.validate", "--seeds 0", "--seeds"),
        ("agents.commands.crash_fe", f"{FE} --interface-contacts 2 --seed -1", "--seed"),
    ],
)
def test_module_commands_share_the_bounds_of_the_railgym_flags(module, argv, flag, capsys):
    """The ``python -m`` commands parse ``--duration``, ``--track-class``, ``--seeds`` and
    ``--seed`` with the same types (and bounds) as ``railgym evaluate``."""
    import importlib

    with pytest.raises(SystemExit) as exc:
        importlib.import_module(module).main(argv.split())
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert exc.value.code == 2 and f"argument {flag}" in last, last


class _Touch:
    """Pickle payload: unpickling it creates ``path`` (stands for any code)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (Path.touch, (self.path,))


def _crafted(tmp_path: Path) -> Path:
    """A run folder (config, no manifest) whose zip's policy.pth is a pickle that runs code."""
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.yaml").write_text(yaml.safe_dump({ENV_ID: TINY}))
    with zipfile.ZipFile(run / "model.zip", "w") as zf:
        zf.writestr("policy.pth", pickle.dumps(_Touch(tmp_path / "pwned")))
    return run / "model.zip"


#: (argv of ``railgym`` in a fresh process, texts stderr must match, texts it must not hold)
FRESH_ROWS = [
    (
        # --trust: one warning line, then railgym's own refusal of policy.pth; never torch's
        # advice to load it unsafely, nor a line of Python source
        "evaluate {crafted} --trust --episodes 1",
        [
            r"(?m)^railgym evaluate: warning: policy \S+model\.zip: no manifest\.json beside it, "
            r".*because of --trust$",
            r"(?m)^railgym evaluate: error: policy \S+model\.zip: policy\.pth is not a "
            r"weights-only state dict: .*never unpickles such objects .*save\(\)",
        ],
        ["weights_only", "add_safe_globals", "warnings.warn", "check_manifest(", "UserWarning"],
    ),
]


@pytest.mark.parametrize(("argv", "want", "never"), FRESH_ROWS, ids=[r[0] for r in FRESH_ROWS])
def test_command_in_a_fresh_process_writes_only_railgym_lines(tmp_path, argv, want, never):
    args = argv.format(crafted=_crafted(tmp_path)).split()
    proc = subprocess.run(
        [sys.executable, "-m", "agents.commands.cli", *args],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
        check=False,
    )
    err = proc.stderr
    assert proc.returncode == 2, err
    for pattern in want:
        assert re.search(pattern, err), err
    for text in ["Traceback", *never]:
        assert text not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines and all(line.startswith(f"railgym {args[0]}: ") for line in lines), err
    assert not (tmp_path / "pwned").exists()


def test_railgym_version_names_the_installed_distribution():
    import subprocess
    import sys
    from importlib.metadata import version

    done = subprocess.run(
        [sys.executable, "-m", "agents.commands.cli", "--version"], capture_output=True, text=True
    )
    assert done.returncode == 0 and done.stdout.strip() == f"railgym {version('railgym')}"


@pytest.mark.parametrize("name", ["train", "benchmark", "pretrained", "validate", "crash-report"])
def test_module_commands_are_railgym_subcommands(name, monkeypatch):
    """``railgym NAME`` runs the module's own parser: the same arguments and help."""
    import importlib
    import os
    import subprocess
    import sys

    from agents.commands.cli import MODULE_COMMANDS

    monkeypatch.setenv("COLUMNS", "80")
    via = subprocess.run(
        [sys.executable, "-m", "agents.commands.cli", name, "--help"],
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "80"},
    )
    direct = importlib.import_module(MODULE_COMMANDS[name][0]).build_parser().format_help()
    assert via.returncode == 0
    assert via.stdout == direct and "usage:" in via.stdout
