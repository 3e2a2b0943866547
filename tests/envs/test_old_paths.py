"""The module paths of the flat layout re-export the moved names for one version."""

import importlib

import pytest

MOVED = {
    "railgym.envs.vertical_batch": ("railgym.envs.vertical.batch", "VerticalBatch"),
    "railgym.envs.vehicle_batch": ("railgym.envs.vehicle.batch", "VehicleBatch"),
    "railgym.envs.vehicle_render": ("railgym.envs.vehicle.render", "render_vehicle"),
    "railgym.envs.rendering": ("railgym.envs.vertical.render", "render_vertical"),
    "railgym.envs.crash_batch": ("railgym.envs.crash.batch", "CrashBatch"),
    "railgym.envs.crash_layout": ("railgym.envs.crash.layout", "INFO_FIELDS"),
    "railgym.envs.crash_params": ("railgym.envs.crash.params", "CrashParams"),
    "railgym.envs.crash_step": ("railgym.envs.crash.step", "crush_limits"),
}


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_module_re_exports_the_moved_names(old):
    new, name = MOVED[old]
    module = importlib.import_module(old)
    assert getattr(module, name) is getattr(importlib.import_module(new), name)
    for exported in module.__all__:
        assert hasattr(module, exported)


def test_the_env_packages_keep_the_old_modules_names():
    from railgym.envs.crash import TrainCrashEnv, default_surrogate  # noqa: F401
    from railgym.envs.vehicle import VehicleParams, VerticalVehicleEnv  # noqa: F401
    from railgym.envs.vertical import (  # noqa: F401
        ACC_REF,
        LIMITS,
        TrackEnvShell,
        VerticalSuspensionEnv,
        check_speed_limit,
        element_arrays,
    )
    from railgym.envs.vertical.env import VerticalSuspensionEnv as moved

    assert VerticalSuspensionEnv is moved
