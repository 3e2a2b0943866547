"""No packaged config, pretrained policy or command default on an outdated env version: every
railgym env id they name is the newest registered version of its env (issue 45, item 6)."""

import re
from pathlib import Path

import pytest
import yaml

import railgym  # noqa: F401  (registers the envs)
from agents.evaluation.evaluate import ENV_IDS
from agents.policies.pretrained import PRETRAINED, RANKING
from railgym.registration import ENVS, env_family, newest

ROOT = Path(__file__).resolve().parents[3]
CONFIGS = sorted((ROOT / "railgym" / "configs" / "agents").glob("*.y*ml"))
PRETRAINED_DIR = ROOT / "agents" / "pretrained"
#: a railgym env id as configs and rl-zoo3's log folders spell it
ID = re.compile(r"railgym[/-](VerticalSuspension|VerticalVehicle|TrainCrash)-v(\d+)")


def _outdated(text: str) -> list[str]:
    return [
        m.group(0)
        for m in ID.finditer(text)
        if f"railgym/{m.group(1)}-v{m.group(2)}" != newest(f"railgym/{m.group(1)}")
    ]


def test_newest_is_the_highest_registered_version():
    assert newest("railgym/VerticalSuspension-v0") == "railgym/VerticalSuspension-v3"
    assert newest("railgym/VerticalVehicle") == "railgym/VerticalVehicle-v3"
    assert newest("railgym/TrainCrash-v1") == "railgym/TrainCrash-v1"
    for env_id in ENVS:
        assert int(env_id.rsplit("-v", 1)[1]) <= int(newest(env_id).rsplit("-v", 1)[1])
    with pytest.raises(ValueError, match="no railgym env"):
        newest("CartPole-v1")


def test_the_pattern_finds_an_outdated_id():
    assert _outdated("railgym/VerticalVehicle-v1: {}  # railgym/TrainCrash-v1") == [
        "railgym/VerticalVehicle-v1"
    ]


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.name)
def test_every_packaged_config_names_the_newest_version(path):
    text = path.read_text()
    assert ID.search(text), f"{path.name} names no railgym env"
    assert _outdated(text) == [], path.name
    envs = [k for k in yaml.safe_load(text) if isinstance(k, str) and "/" in k]
    assert envs and all(e == newest(e) for e in envs), envs


def test_there_are_packaged_configs():
    assert len(CONFIGS) >= 10


@pytest.mark.parametrize("name", sorted(PRETRAINED))
def test_every_pretrained_policy_was_trained_on_the_newest_version(name):
    assert PRETRAINED[name] == newest(PRETRAINED[name])
    config = yaml.safe_load((PRETRAINED_DIR / name / "config.yaml").read_text())
    (env_id,) = [k for k in config if k != "run"]
    assert env_id == PRETRAINED[name]


def test_the_ranking_covers_every_pretrained_env_and_evaluate_defaults_to_the_newest():
    assert {env_family(e) for e in PRETRAINED.values()} <= set(RANKING)
    assert ENV_IDS == {
        "vertical": "railgym/VerticalSuspension-v3",
        "vehicle": "railgym/VerticalVehicle-v3",
        "crash": "railgym/TrainCrash-v1",
    }
