import base64
import json
import pickle
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml

from agents.cli import main
from agents.evaluate import RLLIB_MODULE_PATH, evaluate, evaluate_crash, format_rows, load_policy
from agents.policy_io import write_manifest


def test_evaluate_vertical_skyhook_beats_passive_on_the_same_tracks():
    rows = evaluate(["passive", "skyhook"], backend="linear", track_classes=(6,), episodes=2)
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
    (folder / "config.yaml").write_text(yaml.safe_dump({"railgym/VerticalSuspension-v0": block}))
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
        (lambda: evaluate(["passive"], episodes=0), "episodes"),
        (lambda: evaluate(["passive"], episodes=True), "episodes"),
        (lambda: evaluate(["passive"], seed=-1), "seed"),
        (lambda: evaluate(["passive"], track_classes=(7,)), "track_classes"),
        (lambda: evaluate_crash(["passive"], speeds_kmh=(-40.0,)), "speeds_kmh.*-40.0 km/h"),
        (lambda: evaluate_crash(["passive"], speeds_kmh=("40",)), "speeds_kmh"),
    ],
)
def test_bad_evaluate_arguments_name_the_argument(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_rllib_checkpoint_without_the_extra_is_a_clear_error(tmp_path, monkeypatch):
    (tmp_path / "ckpt" / RLLIB_MODULE_PATH).mkdir(parents=True)
    monkeypatch.setitem(sys.modules, "agents.train_rllib", None)  # as if ray were absent
    with pytest.raises(ValueError, match="install the 'rllib' extra"):
        load_policy(str(tmp_path / "ckpt"))
