"""The reference model as an FMU, and an FMU as the reference (``backend="fmu"``).

Round trip: ``railgym export-reference-fmu`` writes the dynamic vertical reference in C; an
episode on ``backend="fmu"`` with it (co-simulation and model exchange) reproduces the
``backend="reference"`` episode under the same actions.
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from agents.commands.cli import main
from tests.markers import needs_cc

fmpy = pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")
pytestmark = needs_cc

ID = "railgym/VerticalSuspension-v1"


def _export_by_cli(out, env: str):
    """``(fmu, mapping)`` of the reference model of ``env`` (ME and CS) exported to ``out``
    by ``railgym export-reference-fmu``."""
    assert main(["export-reference-fmu", "--env", env, "-o", str(out)]) == 0
    return out, out.with_suffix(".yaml")


@pytest.fixture(scope="module")
def reference_fmu(tmp_path_factory):
    """``(fmu, mapping)`` of the exported vertical reference (ME and CS), by the CLI."""
    return _export_by_cli(tmp_path_factory.mktemp("ref") / "vehicle.fmu", "vertical")


def _episode(env, actions, seed=3):
    env.reset(seed=seed)
    rows = []
    for a in actions:
        obs, reward, term, trunc, info = env.step(a)
        acc = np.ravel(info["carbody_acc"])  # vehicle: floor points front, centre, rear
        rows.append([*obs, reward, *acc, info["bump_stop_contacts"]])
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
    with pytest.raises(ValueError, match="fmu_map is required with backend='fmu'"):
        gym.make("railgym/VerticalVehicle-v1", backend="fmu")
    env = gym.make(ID, backend="fmu", fmu_map=mapping)  # the FMU from the map's fmu:
    with pytest.raises(TypeError, match="cannot be copied"):
        import copy

        copy.deepcopy(env.unwrapped)


def test_collect_from_the_fmu_equals_the_built_in_collection(reference_fmu):
    """Stage 1 on your model: the design's runs on the FMU (passive and actuator-excited)
    give the training data of the built-in reference."""
    from railgym.fmu.collect import collect_fmu
    from railgym.vehicles.collect_design import CollectionDesign, collect_design

    fmu, mapping = reference_fmu
    design = CollectionDesign(track_classes=(5,), speed_factors=(1.0,), duration=3.0)
    got, ref = collect_fmu(mapping, design), collect_design(design)
    assert [r["excited"] for r in got["runs"]] == [False, True]
    assert np.ptp(got["runs"][1]["force_a"]) > 1000.0
    assert got["U"].shape == ref["U"].shape == (302, 2)
    np.testing.assert_allclose(got["U"], ref["U"], rtol=0, atol=1e-12 * np.abs(ref["U"]).max())
    np.testing.assert_allclose(got["V"], ref["V"], rtol=0, atol=1e-12 * np.abs(ref["V"]).max())
    for a, b in zip(got["runs"], ref["runs"], strict=True):
        assert a["contacts"] == b["contacts"]
        scale = np.abs(b["a2"]).max()
        np.testing.assert_allclose(a["a2"], b["a2"], rtol=0, atol=1e-12 * scale)
    # the same without the FMU's secondary_force output: F_s = m2·ẍ2 − F_a
    text = mapping.read_text().replace("  secondary_force: secondary_force\n", "")
    assert "secondary_force" not in text
    bare = mapping.with_name("bare.yaml")
    bare.write_text(text)
    got = collect_fmu(bare, design, fmu=fmu)
    np.testing.assert_allclose(got["V"], ref["V"], rtol=0, atol=1e-9 * np.abs(ref["V"]).max())


@pytest.mark.slow
def test_element_collected_from_the_fmu_is_the_packaged_element(reference_fmu, tmp_path):
    """``railgym collect --fmu-map`` with the packaged element's recipe (its regeneration
    scores its degree grid, not widened, and its τ values): the memory element built on the
    reference FMU's paper run is the packaged one (which meets docs/validation.md)."""
    from agents.commands.collect import main as collect_main
    from railgym.vehicles.collect import default_vertical_surrogate
    from railgym.vehicles.memory_element import PACKAGED_GRID, PACKAGED_TAUS
    from surrogates import io

    _, mapping = reference_fmu
    out = tmp_path / "element.json"
    flags = ["--features", "maxwell", "--max-degree", *map(str, PACKAGED_GRID)]
    flags += ["--tau", *map(str, PACKAGED_TAUS)]
    assert collect_main([*flags, "--fmu-map", str(mapping), "--out", str(out)]) == 0
    model, packaged = io.load(out), default_vertical_surrogate()
    assert model.degree == packaged.degree and model.features_["tau"] == packaged.features_["tau"]
    scale = np.abs(packaged.coef_).max()
    np.testing.assert_allclose(model.coef_, packaged.coef_, rtol=0, atol=1e-9 * scale)


def test_refine_on_the_fmu_equals_refine_on_the_reference(reference_fmu):
    """Policy-aware refinement with the FMU as the reference: the same held-out errors and
    the same refined element as with the built-in dynamic reference."""
    from railgym.fmu.collect import refine_fmu
    from railgym.vehicles.collect import RefineOptions, collect_vertical, refine
    from surrogates.models.lpr import LegendreRegression

    fmu, mapping = reference_fmu
    d = collect_vertical("dynamic", track_class=6, duration=3.0, sample_rate=200.0, seed=3)
    model = LegendreRegression(degree=(4, 4)).fit(d["U"], d["V"])
    law = lambda o: np.clip(4.0 * o[3], -1.0, 1.0)  # noqa: E731  (carbody velocity feedback)
    options = RefineOptions(duration=3.0, n_tracks=1, n_holdout=1, n_add=100)
    kw = dict(data=(d["U"], d["V"]), options=options, log=None)
    ref_model, ref_hist = refine(model, law, rounds=1, **kw)
    fmu_model, fmu_hist = refine_fmu(model, law, rounds=1, fmu_map=mapping, fmu=fmu, **kw)
    assert [h["n_samples"] for h in fmu_hist] == [h["n_samples"] for h in ref_hist]
    for a, b in zip(fmu_hist, ref_hist, strict=True):
        assert a["error"] == pytest.approx(b["error"], rel=1e-8)
    assert ref_hist[0]["error"] > 0.01  # a real difference between element and reference
    U = d["U"]
    scale = np.abs(ref_model.predict(U)).max()
    np.testing.assert_allclose(fmu_model.predict(U), ref_model.predict(U), atol=1e-8 * scale)


def test_fmu_vector_env_equals_the_reference_vector_env_through_autoreset(reference_fmu):
    fmu, mapping = reference_fmu
    kw = {"num_envs": 3, "vectorization_mode": "vector_entry_point", "duration": 0.3}
    envs = [
        gym.make_vec(ID, backend="fmu", fmu=fmu, fmu_map=mapping, **kw),
        gym.make_vec(ID, backend="reference", **kw),
    ]
    outs: list[list] = [[], []]
    for env in envs:
        env.reset(seed=7)
    actions = np.random.default_rng(0).uniform(-1, 1, (45, 3, 1)).astype(np.float32)
    for a in actions:  # 30 steps per episode: two autoresets
        for env, out in zip(envs, outs, strict=True):
            obs, reward, term, trunc, info = env.step(a)
            out.append(np.column_stack([obs, reward, trunc, info["carbody_acc"]]))
    got, ref = np.array(outs[0]), np.array(outs[1])
    assert ref[:, :, 6].sum() == 3  # every sub-env truncated once
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("kind", ["me", "cs"])
def test_single_kind_fmus_are_valid_and_accepted_as_the_reference(kind, tmp_path):
    """``--fmu-kind me`` / ``--fmu-kind cs``: a model-exchange-only and a co-simulation-only FMU,
    each the reference without naming ``fmi_type`` (the one the FMU has is used)."""
    from fmpy.validation import validate_fmu

    out = tmp_path / f"vehicle_{kind}.fmu"
    argv = ["export-reference-fmu", "--env", "vertical", "-o", str(out), "--fmu-kind", kind]
    assert main(argv) == 0
    assert validate_fmu(str(out)) == []
    md = fmpy.read_model_description(str(out))
    assert (md.modelExchange is not None, md.coSimulation is not None) == (
        kind == "me",
        kind == "cs",
    )
    kw = {"duration": 0.5, "track_class": 6}
    actions = np.random.default_rng(3).uniform(-1, 1, (50, 1)).astype(np.float32)
    ref = _episode(gym.make(ID, backend="reference", **kw), actions)
    got = _episode(gym.make(ID, backend="fmu", fmu_map=out.with_suffix(".yaml"), **kw), actions)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


VEHICLE_ID = "railgym/VerticalVehicle-v1"


@pytest.fixture(scope="module")
def vehicle_fmu(tmp_path_factory):
    """``(fmu, mapping)`` of the exported whole-vehicle reference (ME and CS), by the CLI."""
    return _export_by_cli(tmp_path_factory.mktemp("veh") / "whole.fmu", "vehicle")


@pytest.mark.parametrize("fmi_type, tol", [("CoSimulation", 5e-6), ("ModelExchange", 1e-12)])
def test_whole_vehicle_fmu_backend_reproduces_the_reference(vehicle_fmu, fmi_type, tol, tmp_path):
    """VerticalVehicle-v1 on its reference FMU: model exchange gets every RK4 stage's wheelset
    input from the env (bit for bit); co-simulation passes each wheelset's Hermite
    derivatives over the 2 ms step, which differ from the env's piecewise interpolation at
    the wheelsets' fractional sample offsets (measured: 2.9e-7 of the floor acceleration,
    1.1e-6 of the smallest observation channel's range)."""
    from fmpy.validation import validate_fmu

    fmu, mapping = vehicle_fmu
    assert validate_fmu(str(fmu)) == []
    (tmp_path / "map.yaml").write_text(mapping.read_text() + f"fmi_type: {fmi_type}\n")
    kw = {"duration": 1.0, "track_class": 5}
    actions = np.random.default_rng(4).uniform(-1, 1, (100, 2)).astype(np.float32)
    ref = _episode(gym.make(VEHICLE_ID, backend="reference", **kw), actions)
    env = gym.make(VEHICLE_ID, backend="fmu", fmu=fmu, fmu_map=tmp_path / "map.yaml", **kw)
    got = _episode(env, actions)
    assert got.shape == ref.shape == (100, 16)  # 11 observations, reward, 3 floor acc, contacts
    scale = np.abs(ref).max(axis=0)
    assert np.all(np.abs(got - ref) <= tol * scale)
    assert scale[12] > 0.2  # floor acceleration: a real ride


def test_whole_vehicle_fmu_needs_the_sensor_observation(vehicle_fmu):
    fmu, mapping = vehicle_fmu
    with pytest.raises(ValueError, match="observation 'full' needs the vehicle's states"):
        gym.make(VEHICLE_ID, backend="fmu", fmu_map=mapping, observation="full")
    with pytest.raises(ValueError, match="env is 'vehicle', this env is 'vertical'"):
        gym.make(ID, backend="fmu", fmu_map=mapping)


@pytest.mark.parametrize("env", ["vertical", "vehicle"])
def test_evaluate_on_the_fmu_prints_the_reference_table(reference_fmu, vehicle_fmu, env, capsys):
    """``railgym evaluate --backend fmu`` on the exported reference: the table of
    ``--backend reference``, digit for digit."""
    _, mapping = reference_fmu if env == "vertical" else vehicle_fmu
    common = ["evaluate", "skyhook", "--env", env, "--track-class", "4", "--episodes", "1"]
    # -v2: the FMU backend runs the whole-episode tracks of -v2 (it does not stream), so its
    # reference backend rides the same tracks; -v3's reference streams other ones
    common += ["--env-version", "2"]
    if env == "vehicle":
        common += ["--duration", "2"]
    tables = []
    for backend in (["--backend", "reference"], ["--backend", "fmu", "--fmu-map", str(mapping)]):
        assert main(common + backend) == 0
        out = capsys.readouterr().out
        tables.append(out.split("\n", 1)[1])  # without the line naming the backend
    assert tables[0] == tables[1] and "skyhook" in tables[0]


def test_model_exchange_with_fmpys_cvode_converges_to_the_reference(reference_fmu, tmp_path):
    """``solver: cvode``: FMPy's CVode (BDF, restarted at each control step where the
    actuator force jumps) on the model-exchange FMU; the difference to the reference backend
    is the RK4 error of the reference at dt = 1 ms (measured 5.1e-6 relative RMS at
    tolerance 1e-8, 6.4e-5 at 1e-6)."""
    fmu, mapping = reference_fmu
    kw = {"duration": 1.0, "track_class": 5}
    actions = np.random.default_rng(1).uniform(-1, 1, (100, 1)).astype(np.float32)
    ref = _episode(gym.make(ID, backend="reference", **kw), actions)[:, 6]
    errors = []
    for tol in ("1.0e-6", "1.0e-8"):
        path = tmp_path / f"cvode{tol}.yaml"
        path.write_text(
            mapping.read_text() + f"fmi_type: ModelExchange\nsolver: cvode\ntolerance: {tol}\n"
        )
        got = _episode(gym.make(ID, backend="fmu", fmu=fmu, fmu_map=path, **kw), actions)[:, 6]
        errors.append(np.sqrt(np.mean((got - ref) ** 2) / np.mean(ref**2)))
    assert errors[1] < 3e-5 and errors[1] < errors[0] < 1e-3, errors


def test_collect_and_refine_commands_check_their_fmu_arguments(reference_fmu, capsys):
    from agents.commands.collect import main as collect_main

    fmu, mapping = reference_fmu
    with pytest.raises(SystemExit) as info:  # the packaged element is never replaced
        collect_main(["--fmu-map", str(mapping)])
    assert info.value.code == 2 and "--fmu-map needs -o/--out" in capsys.readouterr().err
    assert main(["refine", "passive", "--rounds", "0", "--fmu", str(fmu)]) == 2
    assert "needs its mapping file fmu_map" in capsys.readouterr().err


def test_element_and_reference_fmu_sources_share_the_fmi_functions_and_compile_clean(
    reference_fmu, tmp_path
):
    """Both FMU kinds ship the same ``fmi2_common.h`` (the FMI functions they share) and
    their C files compile without a warning under ``-Wall -Wextra -pedantic``."""
    import subprocess
    import zipfile

    from surrogates.fmi.export import CFLAGS, export_fmu, find_compiler
    from surrogates.models.lpr import LegendreRegression

    u = np.random.default_rng(0).uniform(-1.0, 1.0, (60, 2))
    element = export_fmu(
        LegendreRegression(degree=2).fit(u, u[:, 0] * u[:, 1]), tmp_path / "e.fmu", binary=False
    )
    shared = []
    for fmu, main_c in ((element, "element.c"), (reference_fmu[0], "model.c")):
        src = tmp_path / fmu.stem
        with zipfile.ZipFile(fmu) as zf:
            zf.extractall(src)
            shared.append(zf.read("sources/fmi2_common.h"))
        cmd = [find_compiler(), *CFLAGS, "-Wall", "-Wextra", "-pedantic", "-Werror"]
        proc = subprocess.run(
            [*cmd, "-o", str(tmp_path / f"{fmu.stem}.so"), main_c, "-lm"],
            cwd=src / "sources",
            capture_output=True,
            text=True,
            check=False,
        )
        assert proc.returncode == 0, proc.stderr
    assert shared[0] == shared[1]


@pytest.mark.parametrize("which", ["vertical", "vehicle"])
def test_reference_fmus_declare_base_units_and_one_episode_as_default_experiment(
    reference_fmu, vehicle_fmu, which
):
    """Every unit the FMU uses (the states' time derivatives too: Pa/s, rad/s, rad/s2) is in
    ``UnitDefinitions`` with its SI base units; the default experiment is one episode of the
    env (its default ``duration``) at the FMU's RK4 step; the descriptions hold plain numbers."""
    import zipfile
    from xml.etree import ElementTree

    from fmpy.validation import validate_fmu

    from railgym.envs.vehicle.env import VehicleParams
    from railgym.envs.vertical.env import VerticalParams
    from railgym.vehicles.vehicle.model import DEFAULT_DT as VEHICLE_DT
    from railgym.vehicles.vertical.kernels import DEFAULT_DT

    fmu = (reference_fmu if which == "vertical" else vehicle_fmu)[0]
    assert validate_fmu(str(fmu)) == []
    with zipfile.ZipFile(fmu) as zf:
        root = ElementTree.fromstring(zf.read("modelDescription.xml"))
    declared = {u.get("name"): u.find("BaseUnit") for u in root.iter("Unit")}
    used = {r.get("unit") for r in root.iter("Real") if r.get("unit")}
    assert used == set(declared)
    assert all(base is not None and base.attrib for base in declared.values()), declared
    if which == "vertical":
        assert declared["Pa/s"].attrib == {"kg": "1", "m": "-1", "s": "-3"}
    else:
        assert declared["rad/s2"].attrib == {"rad": "1", "s": "-2"}
    reals = {v.get("name"): v.find("Real") for v in root.iter("ScalarVariable")}
    assert all(r.get("unit") for n, r in reals.items() if n.startswith("der("))
    experiment = root.find("DefaultExperiment").attrib
    params = VerticalParams if which == "vertical" else VehicleParams
    episode = {f.name: f.default for f in dataclasses.fields(params)}["duration"]
    step = DEFAULT_DT["dynamic"] if which == "vertical" else VEHICLE_DT
    assert float(experiment["stopTime"]) == episode == 20.0
    assert float(experiment["stepSize"]) == step
    descriptions = [e.get("description", "") for e in root.iter()]
    assert not any("np." in d for d in descriptions), descriptions
