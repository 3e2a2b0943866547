"""Round trips keep what they read or refuse what they cannot keep; a loaded element is checked
as its fit checks it (passivity, parameters consistent with the saved terms)."""

from __future__ import annotations

import json
from importlib import resources

import numpy as np
import pytest

from surrogates import io
from surrogates.cli import main as surrogates_main
from surrogates.fmi import FMUExportError, export_fmu
from surrogates.models.checks import ModelFieldError

MEMORY = resources.files("railgym").joinpath("data", "vertical_lpr.json")
STATIC = resources.files("railgym").joinpath("data", "vertical_lpr_static.json")


def _doc(source=MEMORY) -> dict:
    return json.loads(source.read_text())


def _write(tmp_path, doc, name="m.json"):
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("source", [MEMORY, STATIC], ids=["maxwell", "static"])
def test_save_of_a_loaded_element_keeps_every_block(tmp_path, source):
    model = io.load(source)
    io.save(model, tmp_path / "again.json")
    again = json.loads((tmp_path / "again.json").read_text())
    original = _doc(source)
    assert again["features"] == original["features"]  # form, tau, known_physics, units
    assert again["metadata"] == original["metadata"]
    assert again["model"] == original["model"]
    U = np.array([[0.01, 0.05, 0.001]])[:, : model.n_features_in_]
    np.testing.assert_array_equal(io.load(tmp_path / "again.json").predict(U), model.predict(U))


def test_the_env_takes_a_resaved_memory_element(tmp_path):
    import gymnasium as gym

    import railgym  # noqa: F401

    io.save(io.load(MEMORY), tmp_path / "again.json")
    env = gym.make("railgym/VerticalSuspension-v1", surrogate=str(tmp_path / "again.json"))
    env.reset(seed=0)
    assert np.isfinite(env.step(np.zeros(1, np.float32))[1])


def test_explicit_arguments_still_override_what_was_read(tmp_path):
    model = io.load(MEMORY)
    io.save(model, tmp_path / "s.json", form="maxwell", tau=0.02)
    assert io.load(tmp_path / "s.json").features_["tau"] == 0.02


def test_an_element_with_every_slope_negated_is_refused_at_load(tmp_path):
    doc = _doc()
    doc["model"]["state"]["coef"] = [-c for c in doc["model"]["state"]["coef"]]
    with pytest.raises(ModelFieldError, match=r"m\.json.*slope of input 0 .* needs it >= 0"):
        io.load(_write(tmp_path, doc))


def test_a_loaded_passive_element_has_its_slope_minima():
    model = io.load(MEMORY)
    assert np.all(model.min_slope_ > 0)  # stiffness, damping, Maxwell stiffness: positive


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("monotone", [True], r"model\.params\.monotone must be True/False or 3 bools"),
        ("grid_size", 1, r"model\.params\.grid_size must be an integer >= 2"),
        ("degree", [14, 14], r"model\.params\.degree=\(14, 14\) does not fit .* 3 inputs"),
        ("degree", [14, 14, 8], r"model\.state\.exponents \(\d+ terms\) are not the terms"),
    ],
)
def test_parameters_inconsistent_with_the_model_are_refused_at_load(
    tmp_path, field, value, message
):
    doc = _doc()
    doc["model"]["params"][field] = value
    with pytest.raises(ModelFieldError, match=message):
        io.load(_write(tmp_path, doc))


def test_fmu_export_of_a_memory_element_is_refused(tmp_path):
    with pytest.raises(FMUExportError, match=r"'maxwell' element \(tau 0\.008 s, known physics"):
        export_fmu(MEMORY, tmp_path / "m.fmu", binary=False)
    assert not (tmp_path / "m.fmu").exists()


def test_cli_export_fmu_of_a_memory_element_is_refused(tmp_path, capsys):
    code = surrogates_main(
        ["export-fmu", str(MEMORY), "-o", str(tmp_path / "m.fmu"), "--sources-only"]
    )
    assert code == 2 and "'maxwell' element" in capsys.readouterr().err
    assert not (tmp_path / "m.fmu").exists()


@pytest.mark.parametrize("ident", ["1bad;rm -rf x", "a b", "é", "", "x-y"])
def test_fmu_model_identifier_must_be_a_c_identifier(tmp_path, ident):
    with pytest.raises(ValueError, match="model_identifier must be a C identifier"):
        export_fmu(STATIC, tmp_path / "m.fmu", binary=False, model_identifier=ident)


def test_fmu_identifier_from_a_file_name_is_ascii(tmp_path):
    import zipfile

    path = export_fmu(STATIC, tmp_path / "1élément-x.fmu", binary=False)
    xml = zipfile.ZipFile(path).read("modelDescription.xml").decode()
    assert 'modelIdentifier="_1_l_ment_x"' in xml


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"{not json", r"bad\.json: not valid JSON"),
        (b"\xff\xfe{}", r"bad\.json: not a UTF-8 text file"),
        (b"[" * 100_000 + b"]" * 100_000, r"bad\.json: JSON nested too deeply"),
    ],
    ids=["syntax", "utf-16", "deep"],
)
def test_fmu_export_of_a_bad_file_names_it(tmp_path, capsys, content, message):
    bad = tmp_path / "bad.json"
    bad.write_bytes(content)
    with pytest.raises(ValueError, match=message):
        export_fmu(bad, tmp_path / "m.fmu", binary=False)
    code = surrogates_main(
        ["export-fmu", str(bad), "-o", str(tmp_path / "m.fmu"), "--sources-only"]
    )
    err = capsys.readouterr().err
    assert code == 2 and "bad.json" in err and "Traceback" not in err


@pytest.mark.parametrize("kind", ["lpr", "kriging"])
def test_an_extrapolation_set_to_a_bogus_value_after_fit_is_refused(kind):
    from surrogates import Kriging, LegendreRegression

    u = np.random.default_rng(0).random((30, 2))
    model = (LegendreRegression() if kind == "lpr" else Kriging()).fit(u, u.sum(axis=1))
    model.set_params(extrapolation="bogus")
    with pytest.raises(ModelFieldError, match=r"extrapolation must be one of .* got 'bogus'"):
        model.predict(u * 2)
    with pytest.raises(ModelFieldError, match=r"extrapolation must be one of"):
        model.predict(u)  # inside the box too: the policy is part of the model
    if kind == "lpr":
        with pytest.raises(ModelFieldError, match=r"extrapolation must be one of"):
            model.kernel_arrays()
