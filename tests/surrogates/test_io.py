import json

import numpy as np
import pytest

from surrogates import LegendreRegression, io


@pytest.fixture
def fitted():
    rng = np.random.default_rng(1)
    U = rng.uniform(-1, 1, size=(60, 2)) * [0.03, 0.2]
    V = 4e5 * U[:, 0] + 3e4 * U[:, 1] ** 3 + 8e4 * U[:, 1]
    return LegendreRegression(degree=(2, 3)).fit(U, V), U


def test_round_trip_identical(tmp_path, fitted):
    model, U = fitted
    path = io.save(model, tmp_path / "m.json", inputs=["dz", "dv"], output="F", units={"F": "N"})
    back = io.load(path)
    Uq = np.vstack([U, U * 1.5])  # inside and outside the training box
    np.testing.assert_array_equal(back.predict(Uq), model.predict(Uq))
    assert back.features_["inputs"] == ["dz", "dv"] and back.features_["units"] == {"F": "N"}


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda d: d.update(schema_version=99), "schema_version 99"),
        (lambda d: d.pop("schema_version"), "schema_version"),
        (lambda d: d.update(format="pickle"), "format"),
        (lambda d: d["model"].pop("state"), "state"),
        (lambda d: d["model"].update(kind="nn"), "unknown model kind"),
        (lambda d: d.pop("model"), "'model'"),
    ],
)
def test_bad_documents_raise_clear_errors(tmp_path, fitted, mutate, message):
    doc = io.model_to_document(fitted[0])
    mutate(doc)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=message):
        io.load(path)


def test_corrupt_json(tmp_path):
    path = tmp_path / "c.json"
    path.write_text('{"schema_version": 1, "model": ')
    with pytest.raises(ValueError, match="not valid JSON"):
        io.load(path)


def test_read_csv(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("t,du,F\n0,0.1,5\n0.02,0.2,6\n")
    cols = io.read_csv(path, columns=["du", "F"])
    np.testing.assert_array_equal(cols["du"], [0.1, 0.2])
    np.testing.assert_array_equal(cols["F"], [5.0, 6.0])


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_written_files_follow_the_umask(tmp_path, fitted, umask):
    """Atomic writes go through mkstemp (mode 0600); the result must have the mode a plain
    ``open(path, "w")`` gives: 0666 without the umask's bits."""
    import os

    from railgym.report.output import atomic_path, write_text_atomic
    from surrogates.fmi import export_fmu

    model, _ = fitted
    old = os.umask(umask)
    try:
        plain = tmp_path / "plain.txt"
        plain.write_text("x")
        paths = [io.save(model, tmp_path / "model.json")]
        write_text_atomic(tmp_path / "manifest.json", "{}")
        with atomic_path(tmp_path / "model.zip") as tmp:
            tmp.write_bytes(b"zip")
        paths += [tmp_path / "manifest.json", tmp_path / "model.zip"]
        paths.append(export_fmu(model, tmp_path / "element.fmu", binary=False))
    finally:
        os.umask(old)
    assert plain.stat().st_mode & 0o777 == 0o666 & ~umask
    for path in paths:
        assert path.stat().st_mode & 0o777 == 0o666 & ~umask, path.name
