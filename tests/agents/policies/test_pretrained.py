"""Pretrained policies shipped in the package: by name, manifest, a stored held-out figure."""

import numpy as np
import pytest

from agents.controllers.registry import CRASH_ID, ENV_ID, VEHICLE_ID
from agents.evaluation.evaluate import evaluate_crash
from agents.evaluation.runs import evaluate_vehicle
from agents.evaluation.sweeps import evaluate_sweep
from agents.policies.loading import load_policy
from agents.policies.policy_io import check_manifest
from agents.policies.pretrained import PRETRAINED, pretrained_zip

#: held-out figures of the shipped policies (docs/results.md, issues 23 and 45), reference backend
#: of the env version each was trained on (``PRETRAINED``):
#: a_w (m/s², per floor point on the vehicle) on the track of seed 1000, class 5 at 144 km/h;
#: crash: worst-car peak deceleration (g) at 40 km/h. ``ppo-preview`` and ``ppo-semiactive`` bring
#: their env settings (``preview``, ``actuator``) with them: loaded by name, nothing else given
STORED = {
    "ppo-vertical": 0.2386,
    "ppo-vehicle": [0.2048, 0.1680, 0.2177],
    "ppo-crash": 6.37080,
    "ppo-preview": [0.2085, 0.1670, 0.1792],  # preview 21.56 m, from its config
    "ppo-semiactive": 0.4251,  # actuator semi-active, from its config
}


@pytest.mark.parametrize("name", sorted(PRETRAINED))
def test_loads_by_name_with_its_manifest(name):
    env_id = PRETRAINED[name]
    path = pretrained_zip(name, env_id)
    check_manifest(path)  # raises unless listed with its SHA-256
    factory, env_kwargs, label = load_policy(name, env_id)
    assert label == name and env_kwargs.get("observation", "sensors") == "sensors"
    assert path.stat().st_size < 300_000
    family = env_id.rsplit("-v", 1)[0]
    load_policy(name, f"{family}-v1")  # any version of the env it was trained on
    other = ENV_ID if not ENV_ID.startswith(family) else VEHICLE_ID
    with pytest.raises(ValueError, match=f"is for {env_id}"):
        load_policy(name, other)


def test_ppo_vertical_reproduces_its_figure():
    env_id = PRETRAINED["ppo-vertical"]
    rows = evaluate_sweep(["ppo-vertical"], "reference", [5], episodes=1, env_id=env_id)
    assert rows[0]["a_w"] == pytest.approx(STORED["ppo-vertical"], rel=1e-3)


def test_ppo_vehicle_reproduces_its_figure():
    env_id = PRETRAINED["ppo-vehicle"]
    rows = evaluate_vehicle(["ppo-vehicle"], "reference", [5], episodes=1, env_id=env_id)
    assert np.allclose(rows[0]["a_w"], STORED["ppo-vehicle"], rtol=1e-3)


def test_ppo_preview_reproduces_its_figure_with_its_preview():
    env_id = PRETRAINED["ppo-preview"]
    rows = evaluate_vehicle(["ppo-preview"], "reference", [5], episodes=1, env_id=env_id)
    assert np.allclose(rows[0]["a_w"], STORED["ppo-preview"], rtol=1e-3)
    _, env_kwargs, _ = load_policy("ppo-preview", VEHICLE_ID)
    assert env_kwargs["preview"] == 21.56


def test_ppo_semiactive_reproduces_its_figure_on_the_damper():
    env_id = PRETRAINED["ppo-semiactive"]
    rows = evaluate_sweep(["ppo-semiactive"], "reference", [5], episodes=1, env_id=env_id)
    assert rows[0]["a_w"] == pytest.approx(STORED["ppo-semiactive"], rel=1e-3)
    _, env_kwargs, _ = load_policy("ppo-semiactive", ENV_ID)
    assert env_kwargs["actuator"] == "semi-active"


def test_ppo_crash_reproduces_its_figure():
    rows = evaluate_crash(["passive", "ppo-crash"], "reference", [40.0])
    peak = float(np.max(rows[1]["peak_decel_g"]))
    assert peak == pytest.approx(STORED["ppo-crash"], rel=1e-3)
    assert PRETRAINED["ppo-crash"].rsplit("-v", 1)[0] == CRASH_ID.rsplit("-v", 1)[0]


def _table(out: str) -> dict[str, str]:
    """``policy: row`` of a ``railgym evaluate`` table (one class)."""
    return {ln.split()[1]: ln for ln in out.splitlines()[2:] if ln.strip()}


def test_cli_evaluate_of_a_semi_active_policy_compares_on_its_damper(capsys):
    """Without --actuator the command takes the policy's actuator: passive is damper command 0
    and skyhook the semi-active one, the same rows as with --actuator semi-active."""
    from agents.commands.cli import main

    case = ["--backend", "linear", "--track-class", "4", "--episodes", "1"]
    assert main(["evaluate", "ppo-semiactive", *case]) == 0
    out = capsys.readouterr().out
    assert "actuator: semi-active (passive: damper command 0)" in out.splitlines()[0]
    rows = _table(out)
    assert list(rows) == ["passive", "skyhook", "ppo-semiactive"]
    assert main(["evaluate", "passive", "skyhook", "--actuator", "semi-active", *case]) == 0
    damper = _table(capsys.readouterr().out)
    assert rows["passive"] == damper["passive"] and rows["skyhook"] == damper["skyhook"]


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (
            ["ppo-semiactive", "--actuator", "force"],
            "--actuator force: policy ppo-semiactive was trained with actuator semi-active",
        ),
        (
            ["ppo-vertical", "--actuator", "semi-active"],
            "--actuator semi-active: policy ppo-vertical was trained with actuator force",
        ),
        (["ppo-semiactive", "ppo-vertical"], "trained with different actuators"),
        (["ppo-semiactive", "lqg"], "--actuator semi-active: lqg is a controller of"),
    ],
)
def test_cli_refuses_an_actuator_the_policy_was_not_trained_with(argv, words, capsys):
    from agents.commands.cli import main

    assert main(["evaluate", *argv, "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err
