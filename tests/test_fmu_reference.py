"""The reference model as an FMU, and an FMU as the reference (``backend="fmu"``).

Round trip: ``railgym export-reference-fmu`` writes the dynamic vertical reference in C; an
episode on ``backend="fmu"`` with it (co-simulation and model exchange) reproduces the
``backend="reference"`` episode under the same actions.
"""

from __future__ import annotations

import shutil

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from agents.cli import main

fmpy = pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
pytestmark = pytest.mark.skipif(
    shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler"
)

ID = "railgym/VerticalSuspension-v0"


@pytest.fixture(scope="module")
def reference_fmu(tmp_path_factory):
    """``(fmu, mapping)`` of the exported vertical reference (ME and CS), by the CLI."""
    out = tmp_path_factory.mktemp("ref") / "vehicle.fmu"
    assert main(["export-reference-fmu", "--env", "vertical", "-o", str(out)]) == 0
    return out, out.with_suffix(".yaml")


def _episode(env, actions, seed=3):
    env.reset(seed=seed)
    rows = []
    for a in actions:
        obs, reward, term, trunc, info = env.step(a)
        rows.append([*obs, reward, info["carbody_acc"], info["bump_stop_contacts"]])
        if term or trunc:
            break
    return np.array(rows)


def test_exported_reference_fmu_is_valid_and_mapped(reference_fmu):
    from fmpy.validation import validate_fmu

    fmu, mapping = reference_fmu
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    assert md.coSimulation is not None and md.modelExchange is not None
    assert md.coSimulation.canInterpolateInputs
    assert md.numberOfContinuousStates == 7
    assert "fmu: vehicle.fmu" in mapping.read_text()
    # no overwrite without --overwrite: exit status 2 and the file untouched
    before = fmu.read_bytes()
    assert main(["export-reference-fmu", "--env", "vertical", "-o", str(fmu)]) == 2
    assert fmu.read_bytes() == before


@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_fmu_backend_reproduces_the_reference_backend(reference_fmu, fmi_type, tmp_path):
    fmu, mapping = reference_fmu
    text = mapping.read_text() + f"fmi_type: {fmi_type}\n"
    (tmp_path / "map.yaml").write_text(text)
    kw = {"duration": 1.5, "track_class": 4}
    actions = np.random.default_rng(1).uniform(-1, 1, (150, 1)).astype(np.float32)
    ref = _episode(gym.make(ID, backend="reference", **kw), actions)
    env = gym.make(ID, backend="fmu", fmu=fmu, fmu_map=tmp_path / "map.yaml", **kw)
    got = _episode(env, actions)
    assert got.shape == ref.shape == (150, 8)
    # observations, reward and carbody acceleration: the same equations and the same RK4
    # with the same cubic Hermite track input (CS: through the FMU's input derivatives)
    scale = np.abs(ref).max(axis=0)
    assert np.all(np.abs(got - ref) <= 1e-9 * scale)
    assert np.abs(ref[:, 6]).max() > 0.3  # a real ride, not a vehicle at rest


def test_reference_shadow_on_the_fmu_equals_the_reference_shadow(reference_fmu):
    from railgym.wrappers import ReferenceShadow

    fmu, mapping = reference_fmu
    shadows = {}
    for backend, kw in (("reference", {}), ("fmu", {"fmu": fmu, "fmu_map": mapping})):
        env = ReferenceShadow(gym.make(ID, duration=1.0), reference_backend=backend, **kw)
        env.reset(seed=5)
        actions = np.random.default_rng(2).uniform(-1, 1, (100, 1)).astype(np.float32)
        for a in actions:
            *_, term, trunc, info = env.step(a)
        assert trunc and not term
        shadows[backend] = info["shadow"]
    ref, got = shadows["reference"], shadows["fmu"]
    assert got["reference_backend"] == "fmu" and got["steps"] == ref["steps"] == 100
    for key in ("err_disp", "err_vel", "err_acc", "rms_acc_reference"):
        assert got[key] == pytest.approx(ref[key], rel=1e-9), key
    assert ref["err_acc"] > 1e-3  # the surrogate differs from the reference: a real check


def test_fmu_arguments_only_with_backend_fmu(reference_fmu):
    fmu, mapping = reference_fmu
    with pytest.raises(ValueError, match="fmu_map is only used with backend='fmu'"):
        gym.make(ID, backend="reference", fmu_map=mapping)
    with pytest.raises(ValueError, match="fmu_map is required with backend='fmu'"):
        gym.make(ID, backend="fmu", fmu=fmu)
    env = gym.make(ID, backend="fmu", fmu_map=mapping)  # the FMU from the map's fmu:
    with pytest.raises(TypeError, match="cannot be copied"):
        import copy

        copy.deepcopy(env.unwrapped)
