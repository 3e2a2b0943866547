"""``railgym evaluate --env-id ID`` / ``--env-version N``: the episodes run on that registered
version of the env of ``--env`` (its numbers are those of ``gym.make(ID)`` on the same seed),
the table's header names it, and an id of no registered version of that env is exit 2 naming
the flag and the registered versions."""

from __future__ import annotations

import re
import warnings

import gymnasium as gym
import numpy as np
import pytest

from agents.commands.cli import main
from agents.controllers.classical import Passive
from railgym.comfort import weighted_rms

#: a short vertical case: one episode on class 6, the linear backend (the track still differs
#: between -v2 and -v3: v3 streams it)
CASE = ["--backend", "linear", "--track-class", "6", "--episodes", "1", "--seed", "7"]


def _single_env(env_id: str) -> tuple[float, float]:
    """RMS carbody acceleration and ISO 2631 Wk a_w (m/s²) of the passive controller on one
    ``gym.make(env_id)`` episode, class 6, track seed 7: computed here, step by step."""
    env = gym.make(env_id, backend="linear", track_class=6)
    ctrl = Passive(env)
    obs, _ = env.reset(seed=7)
    acc = []
    while True:
        obs, _, term, trunc, info = env.step(ctrl.predict(obs)[0])
        acc.append(float(info["carbody_acc"]))
        assert not term
        if trunc:
            break
    a = np.array(acc)
    fs = 1.0 / env.unwrapped.cfg.control_dt
    env.close()
    return float(np.sqrt(np.mean(a**2))), float(weighted_rms(a, fs, discard=2.0, lowpass=False))


def _passive_row(out: str) -> tuple[float, float]:
    """RMS ẍ2 and a_w of the passive row of a vertical table."""
    (line,) = [ln for ln in out.splitlines() if re.match(r"\s+6 passive\s", ln)]
    rms, a_w = line.split()[2:4]
    return float(rms), float(a_w)


def test_env_id_runs_that_version_and_versions_differ(capsys):
    flags = ["--env-id", "railgym/VerticalSuspension-v3"]
    assert main(["evaluate", "passive", *CASE, *flags, "--quiet"]) == 0
    v3 = capsys.readouterr().out
    assert v3.startswith("railgym/VerticalSuspension-v3, backend: linear")
    assert main(["evaluate", "passive", *CASE, "--env-version", "2", "--quiet"]) == 0
    v2 = capsys.readouterr().out
    assert v2.startswith("railgym/VerticalSuspension-v2, backend: linear")
    for out, env_id in (
        (v3, "railgym/VerticalSuspension-v3"),
        (v2, "railgym/VerticalSuspension-v2"),
    ):
        rms, a_w = _single_env(env_id)
        assert _passive_row(out) == (round(rms, 3), round(a_w, 3)), env_id
    assert _passive_row(v2)[1] != _passive_row(v3)[1]  # another track: other numbers
    # without the flags: the newest version, named in the header, and -v1 on request
    assert main(["evaluate", "passive", *CASE, "--quiet"]) == 0
    assert capsys.readouterr().out == v3
    assert main(["evaluate", "passive", *CASE, "--env-version", "1", "--quiet"]) == 0
    v1 = capsys.readouterr().out
    assert v1.startswith("railgym/VerticalSuspension-v1, backend: linear")
    assert _passive_row(v1) == tuple(
        round(x, 3) for x in _single_env("railgym/VerticalSuspension-v1")
    )


@pytest.mark.parametrize(
    ("argv", "flag", "listed"),
    [
        (["--env-id", "railgym/VerticalSuspension-v9"], "--env-id", "VerticalSuspension-v3"),
        (["--env-id", "railgym/VerticalVehicle-v2"], "--env-id", "VerticalSuspension-v0"),
        (["--env-id", "CartPole-v1"], "--env-id", "VerticalSuspension-v2"),
        (["--env-version", "9"], "--env-version", "VerticalSuspension-v1"),
        (["--env", "vehicle", "--env-id", "railgym/TrainCrash-v1"], "--env-id", "Vehicle-v3"),
        (["--env", "crash", "--env-version", "2"], "--env-version", "TrainCrash-v1"),
    ],
)
def test_an_id_of_no_registered_version_is_exit_2_naming_the_flag(argv, flag, listed, capsys):
    assert main(["evaluate", "passive", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"railgym evaluate: error: {flag}: ")
    assert "registered: " in err[0] and listed in err[0]


def test_env_id_and_env_version_exclude_each_other(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(
            [
                "evaluate",
                "passive",
                "--env-id",
                "railgym/VerticalSuspension-v2",
                "--env-version",
                "2",
            ]
        )
    assert exit_.value.code == 2
    assert "--env-version: not allowed with argument --env-id" in capsys.readouterr().err
    # the crash envelope runs its own env version only: another one is refused, not replaced
    assert main(["evaluate", "passive", "--env", "crash", "--envelope", "--env-version", "0"]) == 2
    assert "error: --env-version 0: --envelope runs" in capsys.readouterr().err
    argv = ["evaluate", "passive", "--env", "crash", "--gap", "--env-id", "railgym/TrainCrash-v0"]
    assert main(argv) == 2
    assert "error: --env-id railgym/TrainCrash-v0: --gap on --env crash" in capsys.readouterr().err


def test_version_warning_printed_once_over_workers(tmp_path, tiny_ppo_block, capfd):
    """A policy trained on -v1 evaluated with ``--env-version 2`` on two cases and two worker
    processes: the "trained on … runs on …" warning once (here, pytest records the main
    process's warnings; the workers' would reach stderr)."""
    pytest.importorskip("stable_baselines3")
    from agents.training.train import train

    out = train({"railgym/VerticalVehicle-v1": tiny_ppo_block()}, tmp_path / "ppo", progress=False)
    argv = ["evaluate", str(out / "model.zip"), "--env", "vehicle", "--env-version", "2"]
    case = ["--backend", "linear", "--track-class", "5", "6", "--episodes", "1", "--duration", "2"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main([*argv, *case, "--speed-kmh", "90", "--workers", "2", "--quiet"]) == 0
    text = "trained on railgym/VerticalVehicle-v1 and runs on railgym/VerticalVehicle-v2"
    recorded = [w for w in caught if text in str(w.message)]
    stdout, stderr = capfd.readouterr()
    assert len(recorded) + stderr.count(text) == 1
    assert stdout.startswith("railgym/VerticalVehicle-v2, backend: linear")
    assert stdout.count(" ppo ") == 2  # both cases ran the policy


def test_gap_runs_both_sides_on_the_env_id():
    from agents.evaluation.gap import gap_vertical

    env_id = "railgym/VerticalSuspension-v3"
    (row,) = gap_vertical(
        ["passive"], (6,), episodes=1, seed=7, backends=("linear", "linear"), env_id=env_id
    )
    _, a_w = _single_env(env_id)
    assert row["surrogate"] == row["reference"] == pytest.approx(a_w, rel=1e-9)


def _crash_row(out: str) -> list[str]:
    """Peak deceleration per car (g) of the passive row at 36 km/h of a crash table."""
    (row,) = [ln.split()[2:4] for ln in out.splitlines() if re.match(r"\s*36 passive ", ln)]
    return row


def _crash_peaks(env_id: str) -> list[str]:
    """The same from ``gym.make(env_id)`` on the surrogate, run here with zero actions."""
    env = gym.make(env_id, backend="surrogate")
    env.reset(seed=0, options={"speed_kmh": 36.0})
    while True:
        *_, term, trunc, info = env.step(np.zeros(env.action_space.shape, np.float32))
        if term or trunc:
            return [f"{x:.2f}" for x in info["peak_decel_g"]]


def test_crash_runs_on_the_env_id_and_its_header_names_it(capsys):
    argv = ["evaluate", "passive", "--env", "crash", "--speed-kmh", "36", "--backend", "surrogate"]
    assert main([*argv, "--env-version", "0", "--quiet"]) == 0
    v0 = capsys.readouterr().out
    assert v0.startswith("railgym/TrainCrash-v0, ")
    assert main([*argv, "--quiet"]) == 0
    v1 = capsys.readouterr().out
    assert v1.startswith("railgym/TrainCrash-v1, ")
    assert _crash_row(v0) == _crash_peaks("railgym/TrainCrash-v0")
    assert _crash_row(v1) == _crash_peaks("railgym/TrainCrash-v1")
    assert _crash_row(v0) != _crash_row(v1)  # v0: global LPR elements, v1: piecewise
