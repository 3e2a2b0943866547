"""The memory the data ask for, on a user's quarter car with an air spring, surge pipe and
reservoir (``user_models/air_spring_car.c``: gas masses as states, linearised loss-angle
peak 23° near 2 Hz): the default ``railgym collect`` chooses one memory state, a τ between
the small- and large-amplitude relaxation times of the pipe, far outside the old grid (4, 8,
16 ms), and the product input δ·ζ (form ``"maxwell_product"``: the gas stiffness grows as the
bellows volume shrinks), and its surrogate env follows the FMU env within the issue's
targets (``docs/fmi.md``, *Memory the data ask for*). Slow: the full collection and 80
episodes."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import yaml

from tests.fmu.user_fmu import USER_MAPPING_YAML, build_user_c_fmu

#: the car's vehicle block: k2 the static stiffness k0 of spring and reservoir, c2 the
#: low-frequency equivalent k1·τ of the surge pipe
AIR_CAR_YAML = """\
vehicle:
  name: air_spring_quarter_car
  m1: 2100.0
  m2: 8150.0
  k1: 2.9e+6
  c1: 2.6e+4
  k2: 3.64e+5
  c2: 2.1e+4
  gravity: 9.81
"""


def _run(args, cwd):
    res = subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, f"{args}: exit {res.returncode}\n{res.stdout}\n{res.stderr}"
    return res.stdout


@pytest.mark.slow
def test_default_element_of_the_air_spring_car(tmp_path):
    fmu = build_user_c_fmu(tmp_path, "air_spring_car")
    (tmp_path / "air_car.yaml").write_text(AIR_CAR_YAML)
    mapping = {**yaml.safe_load(USER_MAPPING_YAML), "fmu": str(fmu), "vehicle": "air_car.yaml"}
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(mapping, sort_keys=False))
    cmd = [
        sys.executable,
        "-m",
        "agents.commands.cli",
        "collect",
        "--fmu-map",
        "map.yaml",
        "-o",
        "el.json",
    ]
    text = _run(cmd, tmp_path)
    assert "memory states: 1 (from the data" in text and "warning: tau" not in text
    assert "map: with the product input" in text  # the coupled LPR only with --coupled
    doc = json.loads((tmp_path / "el.json").read_text())
    assert doc["features"]["form"] == "maxwell_product"
    report = doc["metadata"]["report"]
    tau = report["chosen"]["tau"]
    assert 0.045 < tau < 0.09  # s: the pipe's relaxation, laminar 46 ms, longer when turbulent
    fit = report["linear_fit"]
    assert 3.3e5 < fit["k0"] < 3.9e5 and 7.7e5 < fit["k0"] + fit["k1"] < 8.9e5  # N/m
    table = _run(
        [sys.executable, "-m", "agents.commands.cli", "validate", "--env", "vertical"]
        + ["--element", "el.json", "--backend", "fmu", "--fmu-map", "map.yaml", "--seeds", "5"]
        + ["--track-class", "3", "4", "5", "6", "--controller", "passive", "skyhook"],
        tmp_path,
    )
    rows = [r.split("|") for r in table.splitlines() if r.startswith("| el.json")]
    assert len(rows) == 8 and all(r[5].strip() == "0 of 5" for r in rows)
    medians = [float(r[4].split("/")[0]) for r in rows]
    worst = [float(r[4].split("/")[2]) for r in rows]
    assert max(worst) <= 8.0  # %, the target
    assert max(medians) <= 5.0  # %, the target; measured 2.0-3.7
