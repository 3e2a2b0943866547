"""A policy trained on one version of an env and run on another: the warning is printed once
per policy and env id, however often the policy is loaded (one load per evaluation case)."""

from __future__ import annotations

import warnings

import pytest

pytest.importorskip("stable_baselines3")

from agents.policies.loading import load_policy  # noqa: E402
from agents.training.train import train  # noqa: E402


def test_version_change_is_warned_once(tmp_path, tiny_ppo_block):
    out = train({"railgym/VerticalVehicle-v1": tiny_ppo_block()}, tmp_path / "ppo", progress=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(3):
            load_policy(str(out / "model.zip"), "railgym/VerticalVehicle-v2")
        load_policy(str(out / "model.zip"), "railgym/VerticalVehicle-v1")  # its own version
    runs_on = [w for w in caught if "and runs on railgym/VerticalVehicle-v2" in str(w.message)]
    assert len(runs_on) == 1
    assert not [w for w in caught if "runs on railgym/VerticalVehicle-v1" in str(w.message)]
