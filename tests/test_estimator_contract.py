"""scikit-learn estimator contract of the surrogate models (issue 8 item 7)."""

from __future__ import annotations

import json
from importlib import resources

import numpy as np
import pytest

from surrogates import Kriging, LegendreRegression, io
from surrogates.passive import PassiveLegendreRegression

sklearn_base = pytest.importorskip("sklearn.base")

RNG = np.random.default_rng(2)
U = RNG.uniform(-1.0, 1.0, (30, 2))
V = np.sin(2.0 * U[:, 0]) + U[:, 1] ** 2

CASES = [
    (
        PassiveLegendreRegression,
        {"degree": [3, 3], "extrapolation": "clip", "grid_size": 51, "monotone": [True, False]},
    ),
    (LegendreRegression, {"degree": [3, 2], "interactions": False, "extrapolation": "clip"}),
    (LegendreRegression, {"degree": 4, "interactions": True, "extrapolation": "raise"}),
    (
        Kriging,
        {
            "trend": "linear",
            "kernel": "matern52",
            "nugget": 1e-6,
            "extrapolation": "clip",
            "n_starts": 2,
            "seed": 7,
            "max_samples": 100,
        },
    ),
]


@pytest.mark.parametrize(("cls", "params"), CASES)
def test_init_stores_parameters_as_given(cls, params):
    model = cls(**params)
    got = model.get_params()
    assert set(got) == set(cls.__init__.__code__.co_varnames[1 : len(got) + 1])
    for k, v in params.items():
        assert got[k] is v  # stored exactly, not normalised (a list stays the same list)


def test_init_does_not_validate_fit_does():
    bad = LegendreRegression(degree=-3, extrapolation="cubic")  # no error here
    assert bad.get_params()["degree"] == -3
    with pytest.raises(ValueError, match="extrapolation"):
        bad.fit(U, V)
    with pytest.raises(ValueError, match="kernel"):
        Kriging(kernel="rbf").fit(U, V)


@pytest.mark.parametrize(("cls", "params"), CASES)
def test_sklearn_clone_and_set_params(cls, params):
    model = cls(**params)
    twin = sklearn_base.clone(model)
    assert twin is not model and type(twin) is cls
    assert twin.get_params() == model.get_params()
    assert twin.set_params(extrapolation="linear") is twin
    assert twin.extrapolation == "linear" and model.extrapolation == params["extrapolation"]
    with pytest.raises(ValueError, match=r"invalid parameter\(s\) \['colour'\]"):
        twin.set_params(colour="red")


@pytest.mark.parametrize(("cls", "params"), CASES)
def test_every_hyperparameter_round_trips_through_json(cls, params):
    model = cls(**params).fit(U, V)
    d = json.loads(json.dumps(model.to_dict()))
    assert set(d["params"]) == set(cls().get_params())
    back = cls.from_dict(d)
    expected = {k: tuple(v) if isinstance(v, list) else v for k, v in params.items()}
    assert {k: back.get_params()[k] for k in params} == expected
    W = U if params["extrapolation"] == "raise" else np.vstack([U, U * 1.3])
    np.testing.assert_array_equal(back.predict(W), model.predict(W))


def test_kriging_seed_and_n_starts_change_the_search_and_are_saved():
    a = Kriging(n_starts=1, seed=0).fit(U, V)
    b = Kriging(n_starts=3, seed=5).fit(U, V)
    # more starts: no worse an optimum, up to the optimizer's stopping tolerance (the starts
    # differ by seed, and where each stops depends on the CPU's rounding)
    assert b.log_likelihood_ >= a.log_likelihood_ - 1e-4 * abs(a.log_likelihood_)
    saved = a.to_dict()["params"]
    assert saved["n_starts"] == 1 and saved["seed"] == 0 and saved["max_samples"] == 1000
    c = Kriging(n_starts=3, seed=5).fit(U, V)
    np.testing.assert_array_equal(c.theta_, b.theta_)  # seeded: reproducible bit for bit


def test_old_files_without_the_new_fields_still_load(tmp_path):
    doc = io.model_to_document(Kriging(n_starts=1).fit(U, V))
    for key in ("n_starts", "seed", "max_samples"):
        del doc["model"]["params"][key]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(doc))
    old = io.load(path)
    assert (old.n_starts, old.seed, old.max_samples) == (4, 0, 1000)
    name = "vertical_lpr_static.json"  # the paper's static element, written before this test
    with resources.as_file(resources.files("railgym") / "data" / name) as p:
        packaged = io.load(p)
    assert packaged.get_params() == {
        "degree": (14, 10),
        "interactions": False,
        "extrapolation": "linear",
    }
