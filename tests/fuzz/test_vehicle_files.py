"""Plausibility of user vehicle files, generated from the packaged ones: every number of
``manchester.yaml`` and ``manchester_whole.yaml`` set to what cannot describe a vehicle (0, a
negative, NaN, ±inf) is refused when the file is read, naming the field — or, where such a
value can be physical (0 for an optional term), the env runs with finite observations."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from importlib.resources import files
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest
import yaml

from railgym.vehicles.vehicle.params import load_whole_vehicle
from railgym.vehicles.vertical.params import load_vehicle
from tests.fuzz.runner import judge, rollout
from tests.fuzz.values import Bad

PACKAGED = {
    "manchester": ("railgym/VerticalSuspension-v1", load_vehicle),
    "manchester_whole": ("railgym/VerticalVehicle-v1", load_whole_vehicle),
}
VALUES = [
    Bad("zero", 0.0),
    Bad("negative", -1.0),
    Bad("nan", math.nan),
    Bad("inf", math.inf),
    Bad("-inf", -math.inf),
]


def leaves(doc: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[str, ...]]:
    """The key paths of the numbers of a YAML document."""
    if isinstance(doc, dict):
        for key, value in doc.items():
            yield from leaves(value, (*path, key))
    elif isinstance(doc, int | float) and not isinstance(doc, bool):
        yield path


def with_value(doc: dict, path: tuple[str, ...], value: float) -> dict:
    """A copy of ``doc`` with the number at ``path`` replaced."""
    out = yaml.safe_load(yaml.safe_dump(doc))
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


@pytest.mark.parametrize("name", list(PACKAGED))
def test_every_number_of_a_vehicle_file(name: str, tmp_path: Path) -> None:
    env_id, load = PACKAGED[name]
    text = files("railgym").joinpath("configs", "vehicles", f"{name}.yaml").read_text()
    doc = yaml.safe_load(text)
    if "base" in doc:  # the one-bogie file beside it, by path
        doc["base"] = str(files("railgym").joinpath("configs", "vehicles", f"{doc['base']}.yaml"))
    failures = []
    for path in leaves(doc):
        field = ".".join(path)
        for bad in VALUES:
            file = tmp_path / f"{field}_{bad.kind}.yaml"
            file.write_text(yaml.safe_dump(with_value(doc, path, bad.value)))

            def run(file: Path = file) -> str | None:
                load(str(file))
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    return rollout(gym.make(env_id, backend="reference", vehicle=str(file)), 20)

            wrong = judge(path[-1], bad, run)
            if wrong is not None:
                failures.append(f"{name}: {field} = {bad.value!r} ({bad.kind}): {wrong}")
    assert not failures, f"{len(failures)} failures:\n" + "\n".join(failures)
