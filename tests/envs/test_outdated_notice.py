"""Gymnasium's notice "The environment railgym/X-vN is out of date" is shown at most once per
id and process (railgym.registration), not again after a filter change clears Python's
once-registry, and never for the newest version; a filter the user adds later still decides."""

import os

from tests.fresh_process import ROOT, run_python

SCRIPT = """
import warnings
import gymnasium as gym
import railgym
for i in range(3):
    gym.make("railgym/VerticalVehicle-v1", backend="reference")
    warnings.filterwarnings("ignore", "an unrelated message")  # clears the once-registry
for i in range(2):
    gym.make("railgym/VerticalSuspension-v2")
gym.make("railgym/VerticalSuspension-v3")
gym.make("railgym/VerticalVehicle-v3")
gym.make("railgym/TrainCrash-v1")
warnings.simplefilter("always", DeprecationWarning)
gym.make("railgym/VerticalVehicle-v1", backend="reference")
"""


def test_the_out_of_date_notice_is_shown_once_per_id_unless_the_user_asks_for_more():
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("PYTHONWARNINGS", None)
    run = run_python("-c", SCRIPT, env=env)
    assert run.returncode == 0, run.stderr
    notices = [ln for ln in run.stderr.splitlines() if "is out of date" in ln]
    assert len(notices) == 3, notices
    assert "railgym/VerticalVehicle-v1 is out of date" in notices[0]
    assert "upgrading to version `v3`" in notices[0]
    assert "railgym/VerticalSuspension-v2 is out of date" in notices[1]
    # the user's "always" filter goes in front of railgym's
    assert "railgym/VerticalVehicle-v1 is out of date" in notices[2]
