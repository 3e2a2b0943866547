import base64
import json
import pickle
import subprocess
import sys
import zipfile
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

from agents.commands.cli import main
from agents.controllers.classical import BogieSkyhook
from agents.controllers.registry import VEHICLE_ID
from agents.evaluation.crash_report import envelope_table
from agents.evaluation.evaluate import (
    evaluate_crash,
    evaluate_envelope,
    format_crash_rows,
    format_rows,
    format_vehicle_rows,
)
from agents.evaluation.runs import evaluate_vehicle
from agents.evaluation.sweeps import evaluate_sweep
from agents.policies.loading import load_policy
from agents.policies.policy_io import RLLIB_MODULE_PATH, write_manifest
from railgym.track import class_speed


def test_evaluate_vertical_skyhook_beats_passive_on_the_same_tracks():
    rows = evaluate_sweep(["passive", "skyhook"], backend="linear", track_classes=(6,), episodes=2)
    by = {r["policy"]: r for r in rows}
    assert by["passive"]["a_w_reduction_%"] == 0.0
    assert by["skyhook"]["a_w"] < by["passive"]["a_w"]
    expected = 100 * (1 - by["skyhook"]["a_w"] / by["passive"]["a_w"])
    assert by["skyhook"]["a_w_reduction_%"] == pytest.approx(expected)
    assert all(np.isfinite(r["wz"]) and r["wz"] > 0 for r in rows)
    assert "skyhook" in format_rows(rows)


def test_evaluate_crash_passive_row():
    (row,) = evaluate_crash(["passive"], backend="surrogate", speeds_kmh=(40.0,))
    assert len(row["peak_decel_g"]) == 2 and np.all(np.asarray(row["peak_decel_g"]) > 1.0)
    assert row["peak_reduction_%"] == 0.0


def _single_vehicle_runs(
    episode: Callable, kwargs: dict, seeds: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """RMS floor accelerations (from every step's ``carbody_acc``) and the end-of-episode
    Wk a_w of single envs under skyhook per bogie, one row per seed."""
    runs = []
    for seed in seeds:
        env = gym.make(VEHICLE_ID, **kwargs)
        runs.append(episode(env, BogieSkyhook(env), seed))
    return np.array([rms for rms, _ in runs]), np.array([i["comfort"]["a_w"] for _, i in runs])


def test_evaluate_vehicle_rows_are_the_means_of_single_envs_per_floor_point(controlled_episode):
    kw = {"backend": "linear", "track_classes": (6,), "episodes": 2, "seed": 3, "duration": 6.0}
    rows = evaluate_vehicle(["passive", "skyhook"], speeds_kmh=(None, 100.0), **kw)
    assert [(r["policy"], round(r["speed_kmh"], 6)) for r in rows] == [
        ("passive", round(class_speed(6) * 3.6, 6)),
        ("skyhook", round(class_speed(6) * 3.6, 6)),
        ("passive", 100.0),
        ("skyhook", 100.0),
    ]
    env_kw = {"backend": "linear", "track_class": 6, "speed": 100 / 3.6, "duration": 6.0}
    # sub-env i = the single env of seed 3 + i
    rms, a_w = _single_vehicle_runs(controlled_episode, env_kw, [3, 4])
    np.testing.assert_allclose(rows[3]["rms_acc"], rms.mean(axis=0), rtol=1e-9)
    np.testing.assert_allclose(rows[3]["a_w"], a_w.mean(axis=0), rtol=1e-9)
    passive, sky = rows[0], rows[1]
    # the bogie spacing filters the track: the centre rides better than both ends (passive)
    assert passive["rms_acc"][1] < 0.7 * min(passive["rms_acc"][0], passive["rms_acc"][2])
    assert np.all(sky["a_w"] < passive["a_w"])  # skyhook helps at every floor point
    np.testing.assert_allclose(sky["a_w_reduction_%"], 100 * (1 - sky["a_w"] / passive["a_w"]))
    np.testing.assert_array_equal(passive["a_w_reduction_%"], 0.0)
    for r in rows:
        assert r["rms_acc"].shape == r["a_ZP95_Wb"].shape == r["Wz"].shape == (3,)
        assert np.all(r["Wz"] > 0) and r["contacts"] == 0.0
    assert "skyhook" in format_vehicle_rows(rows)


def test_evaluate_vehicle_same_rows_on_one_and_two_workers():
    kw = {"backend": "linear", "track_classes": (5, 6), "episodes": 1, "seed": 11, "duration": 5.0}
    one = evaluate_vehicle(["passive", "modal-skyhook"], **kw)
    two = evaluate_vehicle(["passive", "modal-skyhook"], **kw, workers=2)
    assert [(r["track_class"], r["policy"]) for r in two] == [
        (5, "passive"),
        (5, "modal-skyhook"),
        (6, "passive"),
        (6, "modal-skyhook"),
    ]
    for a, b in zip(one, two, strict=True):
        assert a.keys() == b.keys()
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])  # bit for bit


def test_cli_evaluate_same_table_on_one_and_two_workers(capsys):
    argv = ["evaluate", "passive", "--backend", "linear", "--track-class", "6", "--episodes", "1"]
    assert main([*argv, "--env", "vehicle", "--duration", "5", "--speed-kmh", "90"]) == 0
    one = capsys.readouterr().out
    assert (
        main([*argv, "--env", "vehicle", "--duration", "5", "--speed-kmh", "90", "--workers", "2"])
        == 0
    )
    assert capsys.readouterr().out == one
    assert "   90 skyhook" in one and "   90 passive" in one  # passive and skyhook always run
    assert main([*argv, "--workers", "2"]) == 0
    two = capsys.readouterr().out
    assert main(argv) == 0
    assert capsys.readouterr().out == two


def test_address_without_ray_is_exit_2_naming_the_extra(monkeypatch, capsys):
    monkeypatch.setattr("railgym.parallel.ray_available", lambda: False)
    for env in ("vertical", "vehicle"):
        assert main(["evaluate", "skyhook", "--env", env, "--address", "10.0.0.5:6379"]) == 2
        err = capsys.readouterr().err
        assert "--address" in err and "railgym[ray]" in err and "Traceback" not in err


def test_envelope_evaluation_of_the_baselines_at_one_speed(capsys):
    rows = evaluate_envelope(["passive"], speeds_kmh=(40.0,))
    assert [(r["controller"], r["payload_t"]) for r in rows] == [
        (name, payload)
        for payload in ((0.0, 0.0), (2.0, 8.0))
        for name in ("passive", "best-constant", "speed-adaptive")
    ]
    empty, loaded = (r["criteria"] for r in rows if r["controller"] == "passive")
    assert not np.array_equal(loaded.peak_decel_g, empty.peak_decel_g)  # the payload is applied
    assert empty.all_passed  # the EN 15227 design case passes on the passive train
    assert main(["evaluate", "passive", "--env", "crash", "--envelope", "--speed-kmh", "40"]) == 0
    out = capsys.readouterr().out
    assert envelope_table(rows) in out and out.count("| 40 |") == 6


def test_envelope_evaluation_runs_a_crash_policy_zip_beside_the_baselines(tmp_path, tiny_ppo_block):
    pytest.importorskip("stable_baselines3")
    from agents.training.train import train

    block = tiny_ppo_block(
        n_timesteps=64,
        n_envs=1,
        vectorization_mode="sync",
        env_kwargs={"backend": "surrogate", "scenario": "envelope", "control_dt": 0.005},
    )
    out = train({"railgym/TrainCrash-v1": block}, tmp_path / "ppo_crash", progress=False)
    rows = evaluate_envelope([str(out / "model.zip"), "passive"], speeds_kmh=(30.0,))
    names = ("passive", "best-constant", "speed-adaptive", "ppo_crash")
    assert [r["controller"] for r in rows] == list(names) * 2
    for r in rows:
        c = r["criteria"]
        assert np.all(np.isfinite(c.peak_decel_g)) and np.all(c.intrusion_m >= 0.0)


def test_vehicle_policy_zip_is_loaded_with_the_manifest(tmp_path, capsys, tiny_ppo_block):
    pytest.importorskip("stable_baselines3")
    from agents.training.train import train

    block = tiny_ppo_block()
    out = train({VEHICLE_ID: block}, tmp_path / "ppo_vehicle", progress=False)
    zip_path = str(out / "model.zip")
    with pytest.raises(ValueError, match=f"trained on {VEHICLE_ID}"):
        load_policy(zip_path)  # not a vertical-env policy
    (row,) = evaluate_vehicle(
        [zip_path], backend="linear", track_classes=(6,), episodes=1, duration=5.0
    )
    assert row["policy"] == "ppo_vehicle" and np.all(np.isfinite(row["a_w"]))
    (out / "manifest.json").unlink()
    assert main(["evaluate", zip_path, "--env", "vehicle", "--episodes", "1"]) == 2
    assert "manifest.json" in capsys.readouterr().err


def test_unknown_policy_is_a_clear_error():
    with pytest.raises(ValueError, match="policy must be one of"):
        load_policy("skyhook2")


# ------------------------------------------------------------- untrusted policy files
class _Touch:
    """Pickle payload: unpickling it creates ``path`` (stands for any code)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (Path.touch, (self.path,))


def _crafted_run(folder: Path, sentinel: Path) -> Path:
    """A run folder with a valid config and an SB3-looking zip whose pickled fields run code."""
    folder.mkdir()
    block = {"algo": "ppo", "n_timesteps": 2048, "seed": 0, "policy_kwargs": {"net_arch": [8]}}
    (folder / "config.yaml").write_text(yaml.safe_dump({"railgym/VerticalSuspension-v1": block}))
    payload = pickle.dumps(_Touch(sentinel))
    data = {
        "policy_class": {
            ":type:": "<class 'type'>",
            ":serialized:": base64.b64encode(payload).decode(),
        }
    }
    path = folder / "model.zip"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("data", json.dumps(data))
        zf.writestr("policy.pth", payload)
        zf.writestr("_stable_baselines3_version", "2.3.0")
    return path


def test_crafted_policy_zip_is_refused_and_never_runs(tmp_path, capsys):
    control = tmp_path / "control"
    pickle.loads(pickle.dumps(_Touch(control)))
    assert control.exists()  # the payload does run when unpickled
    sentinel = tmp_path / "pwned"
    path = _crafted_run(tmp_path / "run", sentinel)

    # not listed in a manifest of its training: refused, naming --trust
    assert main(["evaluate", str(path), "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "manifest.json" in err and "--trust" in err and "Traceback" not in err
    # --trust (a warning), or a manifest forged beside it: only policy.pth is read, with
    # torch's weights-only unpickler, which refuses the payload
    with pytest.warns(UserWarning, match="--trust"):
        assert main(["evaluate", str(path), "--trust", "--episodes", "1"]) == 2
    assert "not a weights-only state dict" in capsys.readouterr().err
    write_manifest(path.parent)
    assert main(["evaluate", str(path), "--episodes", "1"]) == 2
    assert "not a weights-only state dict" in capsys.readouterr().err
    assert not sentinel.exists()


def test_a_zip_that_is_no_zip_is_one_clear_error(tmp_path):
    folder = tmp_path / "run"
    _crafted_run(folder, tmp_path / "unused")
    (folder / "model.zip").write_bytes(b"not a zip")
    write_manifest(folder)
    with pytest.raises(ValueError, match="not a zip file"):
        load_policy(str(folder / "model.zip"))


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: evaluate_sweep(["passive"], episodes=0), "episodes"),
        (lambda: evaluate_sweep(["passive"], episodes=True), "episodes"),
        (lambda: evaluate_sweep(["passive"], seed=-1), "seed"),
        (lambda: evaluate_sweep(["passive"], track_classes=(7,)), "track_classes"),
        (lambda: evaluate_crash(["passive"], speeds_kmh=(-40.0,)), "speeds_kmh.*-40.0 km/h"),
        (lambda: evaluate_crash(["passive"], speeds_kmh=("40",)), "speeds_kmh"),
    ],
)
def test_bad_evaluate_arguments_name_the_argument(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_rllib_checkpoint_without_the_extra_is_a_clear_error(tmp_path, monkeypatch):
    (tmp_path / "ckpt" / RLLIB_MODULE_PATH).mkdir(parents=True)
    monkeypatch.setitem(sys.modules, "agents.training.train_rllib", None)  # as if ray were absent
    with pytest.raises(ValueError, match="install the 'rllib' extra"):
        load_policy(str(tmp_path / "ckpt"))


# ----------------------------------------------------- what the tables say (issue reports)
def _railgym(*args: str) -> subprocess.CompletedProcess:
    """``railgym ARGS`` in a fresh process."""
    return subprocess.run(
        [sys.executable, "-m", "agents.commands.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_crash_table_marks_a_run_the_env_cut_as_diverged():
    """At 400 km/h the lead zone crushes through the car (27.6 m on a 27.6 m car): the env ends
    the run as diverged (info["diverged"]); the table marks the row and says so under it."""
    proc = _railgym("evaluate", "passive", "--env", "crash", "--speed-kmh", "400", "40", "--quiet")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[1].split()[-1] == "diverged"
    fast, slow = (ln for ln in lines if ln.strip().startswith(("400 ", "40 ")))
    assert fast.split()[-1] == "yes" and slow.split()[-1] == "no"
    (note,) = [ln for ln in lines if ln.startswith("diverged:")]
    assert note.startswith("diverged: passive at 400 km/h: the env cut the run where its state")
    assert "not a physical result" in note and "passive at 40 km/h" not in note


def test_envelope_table_marks_diverged_runs():
    rows = evaluate_envelope(["passive"], speeds_kmh=(400.0,))
    assert all(r["diverged"] for r in rows)
    text = envelope_table(rows)
    cases = [ln for ln in text.splitlines() if ln.startswith("| 400 |")]
    assert len(cases) == 6 and all(ln.endswith("| yes |") for ln in cases)
    assert "diverged: passive at 400 km/h, payload 0 / 0 t; best-constant" in text
    assert "| max intrusion m ≤ 45 km/h |" in text  # the summary too (NaN: no such case)


def test_help_and_docstring_say_which_rows_are_always_added():
    import agents.evaluation.evaluate

    proc = _railgym("evaluate", "--help")
    assert proc.returncode == 0
    text = " ".join(proc.stdout.split())
    assert "The comparison rows are always added: passive and skyhook (vertical, vehicle)" in text
    assert "passive (crash), passive, best-constant and speed-adaptive (crash --envelope)" in text
    doc = " ".join(agents.evaluation.evaluate.__doc__.split())
    assert "always adds rows to compare against, whether or not they are named" in doc


LONG = "runs/ppo_vertical_long_experiment_name/checkpoints/model_20000_steps"


def test_tables_size_the_policy_column_to_the_longest_name():
    row = {"track_class": 4, "rms_acc": 0.1, "a_w": 0.2, "a_w_reduction_%": 1.0, "wz": 2.0}
    vertical = [{**row, "policy": p, "max_defl_mm": 10.0, "contacts": 0} for p in ("passive", LONG)]
    three = np.array([0.1, 0.2, 0.3])
    vehicle = [
        {
            **row,
            "policy": p,
            "speed_kmh": 100.0,
            **dict.fromkeys(("rms_acc", "a_w", "a_w_reduction_%", "a_ZP95_Wb", "Wz"), three),
            "contacts": 0,
            "ood": 0,
        }
        for p in ("passive", LONG)
    ]
    for text in (format_rows(vertical), format_vehicle_rows(vehicle)):
        head, *lines = text.splitlines()
        assert len({len(ln) for ln in [head, *lines]}) == 1, text  # every column aligned
        at = head.index("policy")
        assert [ln[at:].split()[0] for ln in lines] == ["passive", LONG]
    crash = [
        {
            "speed_kmh": 40.0,
            "policy": p,
            "peak_decel_g": np.array([8.0, 3.5]),
            "max_crush_m": np.array([1.9, 0.6]),
            "stroke_exceeded": False,
            "diverged": False,
            "peak_reduction_%": 0.0,
        }
        for p in ("passive", LONG)
    ]
    head, *lines = format_crash_rows(crash).splitlines()
    assert len({len(ln) for ln in lines}) == 1
    assert all(ln.index("8.00") == head.index("peak decel") for ln in lines)
