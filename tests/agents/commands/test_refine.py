"""``railgym refine`` on the newest env version: its env only designs the policy's controller
and scales the observation, and that scaling is the same on every version of the env, so the
refinement of an element does not depend on the version the command defaults to."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from agents.commands.refine import observation_map, vehicle_observation_map
from agents.controllers.registry import ENV_ID, VEHICLE_ID
from railgym.registration import ENVS, env_family
from railgym.vehicles.collect import RAW_OBSERVATION
from railgym.vehicles.vehicle.refine import RAW_VEHICLE_OBSERVATION

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.mark.parametrize(
    ("default", "mapping", "raw_names"),
    [
        (ENV_ID, observation_map, RAW_OBSERVATION),
        (VEHICLE_ID, vehicle_observation_map, RAW_VEHICLE_OBSERVATION),
    ],
)
@pytest.mark.parametrize("observation", ["sensors", "full"])
def test_the_observation_map_is_that_of_every_version(default, mapping, raw_names, observation):
    """A raw vector maps to the same observation on the default (newest) env as on every
    other registered version of its family, bit for bit."""
    rng = np.random.default_rng(0)
    raw = rng.standard_normal(len(raw_names))
    versions = [e for e in ENVS if env_family(e) == env_family(default)]
    mapped = {
        e: mapping(gym.make(e, backend="reference", observation=observation).unwrapped)(raw)
        for e in versions
    }
    assert default in mapped and len(versions) >= 3
    for env_id, obs in mapped.items():
        np.testing.assert_array_equal(obs, mapped[default], err_msg=env_id)
