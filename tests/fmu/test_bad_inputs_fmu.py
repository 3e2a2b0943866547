"""Bad FMUs and mapping files for ``backend="fmu"``: one clear error naming the file and the
variable (or field), exit status 2 from ``railgym evaluate``, and no hang."""

from __future__ import annotations

import shutil
import time
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import railgym  # noqa: F401  (registers the envs)
from agents.commands.cli import main
from railgym.fmu.mapping import FMUError
from railgym.fmu.reference import export_reference_fmu
from surrogates.fmi.export import compile_sources, fmi_platform
from tests.markers import needs_cc

pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
pytestmark = needs_cc
ID = "railgym/VerticalSuspension-v1"


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    out = tmp_path_factory.mktemp("good") / "vehicle.fmu"
    fmu, mapping = export_reference_fmu(out)
    return fmu, yaml.safe_load(mapping.read_text())


def _rebuild(src: Path, dst: Path, xml=None, c=None, drop_binary=False) -> Path:
    """Copy of the FMU ``src`` with its modelDescription / model.c edited (rebuilt)."""
    with zipfile.ZipFile(src) as zf:
        files = {n: zf.read(n) for n in zf.namelist()}
    if xml is not None:
        files["modelDescription.xml"] = xml(files["modelDescription.xml"].decode()).encode()
    folder, ext = fmi_platform()
    lib = f"binaries/{folder}/vehicle{ext}"
    if c is not None:
        work = dst.parent / (dst.stem + "_src")
        work.mkdir()
        for n, data in files.items():
            if n.startswith("sources/"):
                (work / n[len("sources/") :]).write_bytes(data)
        (work / "model.c").write_text(c((work / "model.c").read_text()))
        files[lib] = compile_sources(work, work / f"lib{ext}", files=("model.c",)).read_bytes()
    if drop_binary:
        files = {n: d for n, d in files.items() if not n.startswith("binaries/")}
    with zipfile.ZipFile(dst, "w") as zf:
        for n, data in files.items():
            zf.writestr(n, data)
    return dst


def _in_do_step(body: str):
    anchor = "    (void)noSetFMUStatePriorToCurrentCommunicationPoint;\n"
    return lambda text: text.replace(anchor, anchor + body, 1)


def _set(doc: dict, dotted: str, value) -> dict:
    out = yaml.safe_load(yaml.safe_dump(doc))
    keys = dotted.split(".")
    node = out
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node[k]
    if value is _DELETE:
        del node[keys[-1]]
    elif isinstance(node, list):
        node[int(keys[-1])] = value
    else:
        node[keys[-1]] = value
    return out


_DELETE = object()

#: (case, mapping edits, FMU edit, words the message must contain)
CASES = [
    ("missing variable", {"outputs.carbody_acc": "a2"}, None, ["outputs.carbody_acc", "'a2'"]),
    ("missing output", {"outputs.bogie_acc": _DELETE}, None, ["outputs.bogie_acc", "missing"]),
    (
        "not an input",
        {"inputs.actuator_force.0": "carbody_acc"},
        None,
        ["inputs.actuator_force[0]", "'carbody_acc'", "causality 'output'", "input"],
    ),
    (
        "output unit does not convert",
        {"outputs.deflection": "carbody_acc"},
        None,
        ["outputs.deflection", "'carbody_acc'", "'m/s2'", "does not convert to m"],
    ),
    (
        "mapped unit does not convert",
        {"inputs.track.0.rate": {"name": "zdot", "unit": "kg"}},
        None,
        ["inputs.track[0].rate", "'zdot'", "'kg'", "m/s"],
    ),
    (
        "wrongly typed variable",
        {},
        {
            "xml": lambda t: t.replace(
                'continuous" initial="calculated" description="carbody vertical acceleration">'
                '<Real unit="m/s2"/>',
                'discrete" initial="calculated" description="carbody vertical acceleration">'
                "<Integer/>",
                1,
            )
        },
        ["outputs.carbody_acc", "'carbody_acc'", "Integer, not Real"],
    ),
    ("wheelset count", {"inputs.track": []}, None, ["inputs.track", "1"]),
    ("unknown field", {"outputz": {}}, None, ["outputz", "unknown"]),
    ("other env", {"env": "crash"}, None, ["env", "'crash'"]),
    ("step is not dt", {"step": 0.002}, None, ["step", "0.002", "dt"]),
    ("solver for co-simulation", {"solver": "cvode"}, None, ["solver", "ModelExchange"]),
    ("tolerance without cvode", {"tolerance": 1e-6}, None, ["tolerance", "cvode"]),
    (
        "unsupported FMI version",
        {},
        {"xml": lambda t: t.replace('fmiVersion="2.0"', 'fmiVersion="3.0"')},
        ["vehicle", "FMI version"],
    ),
    (
        "no binary for this platform",
        {},
        {"drop_binary": True},
        ["vehicle", "no binary", "platform"],
    ),
    (
        "fails to instantiate",
        {},
        {"xml": lambda t: t.replace('guid="{', 'guid="{0', 1)},
        ["vehicle", "instantiate failed", "GUID"],
    ),
    (
        "fails to step",
        {},
        {
            "c": _in_do_step(
                "    if (currentCommunicationPoint > 0.05) {\n"
                '        fmu_log(m, fmi2Error, "test: pump failure");\n'
                "        return fmi2Error;\n    }\n"
            )
        },
        ["vehicle", "fmi2DoStep failed", "pump failure"],
    ),
    (
        "step slower than the timeout",
        {"timeout": 0.3},
        {
            "c": _in_do_step(
                "    if (currentCommunicationPoint > 0.05) {\n"
                "        volatile double s = 0.0;\n        long i;\n"
                "        for (i = 0; i < 4000000000L; i++) s += 1.0;\n    }\n"
            )
        },
        ["vehicle", "timeout of 0.3 s", "timeout"],
    ),
]


@pytest.mark.parametrize("case, edits, fmu_edit, words", CASES, ids=[c[0] for c in CASES])
def test_bad_fmu_or_mapping_gives_one_clear_error(good, tmp_path, case, edits, fmu_edit, words):
    fmu, doc = good
    if fmu_edit is not None:
        fmu = _rebuild(fmu, tmp_path / "vehicle.fmu", **fmu_edit)
    for key, value in edits.items():
        doc = _set(doc, key, value)
    doc["fmu"] = str(fmu)
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(doc))
    t0 = time.perf_counter()
    with pytest.raises(FMUError) as info:
        env = gym.make(ID, backend="fmu", fmu_map=path, duration=0.2)
        env.reset(seed=0)
        for _ in range(20):
            env.step(np.zeros(1, np.float32))
    # no hang: generous, so that a loaded machine does not fail it (the timeout case is 0.3 s)
    assert time.perf_counter() - t0 < 120.0
    msg = str(info.value)
    assert str(path) in msg or str(fmu) in msg
    for word in words:
        assert word in msg, (case, msg)


def _list_mapping(tmp: Path, fmu: Path) -> dict:
    (tmp / "map.yaml").write_text("- version: 1\n- env: vertical\n")
    return {"fmu_map": tmp / "map.yaml", "fmu": fmu}


def _folder_mapping(tmp: Path, fmu: Path) -> dict:
    (tmp / "maps").mkdir()
    return {"fmu_map": tmp / "maps", "fmu": fmu}


def _folder_fmu(tmp: Path, fmu: Path) -> dict:
    (tmp / "unpacked").mkdir()
    shutil.copy(fmu.with_suffix(".yaml"), tmp / "map.yaml")
    return {"fmu_map": tmp / "map.yaml", "fmu": tmp / "unpacked"}


#: (case, env arguments of (tmp_path, the good FMU), texts the message must contain)
FILE_CASES = [
    (
        "mapping is a list",
        _list_mapping,
        [
            "map.yaml: the mapping file must be a YAML mapping (version:, env:, inputs:, "
            "outputs:), got a list"
        ],
    ),
    ("mapping is a folder", _folder_mapping, ["fmu_map", "maps", "is a folder, not a file"]),
    ("fmu is a folder", _folder_fmu, ["fmu", "unpacked", "is a folder, not a file", ".fmu"]),
]


@pytest.mark.parametrize("case, kwargs_of, texts", FILE_CASES, ids=[c[0] for c in FILE_CASES])
def test_mapping_or_fmu_that_is_no_such_file_names_it(good, tmp_path, case, kwargs_of, texts):
    kwargs = kwargs_of(tmp_path, good[0])
    with pytest.raises(FMUError) as info:
        gym.make(ID, backend="fmu", duration=0.2, **kwargs)
    msg = str(info.value)
    for text in texts:
        assert text in msg, (case, msg)
    assert "does not exist" not in msg and not msg.startswith(" ")


def test_evaluate_exits_with_status_2_on_a_bad_fmu(good, tmp_path, capsys):
    fmu, doc = good
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(_set(doc, "outputs.carbody_vel", "nope")))
    args = ["evaluate", "passive", "--backend", "fmu", "--fmu", str(fmu), "--fmu-map", str(path)]
    assert main([*args, "--track-class", "4", "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "outputs.carbody_vel" in err and "'nope'" in err and str(path) in err
    assert main(["evaluate", "passive", "--fmu-map", str(path)]) == 2
    assert "only with --backend fmu" in capsys.readouterr().err
