"""Policy-aware refinement (railgym.vehicles.collect.refine) on a toy reference."""

from __future__ import annotations

import numpy as np
import pytest

from railgym.vehicles.collect import RefineOptions, collect_vertical, refine
from surrogates.models.lpr import LegendreRegression


@pytest.fixture(scope="module")
def toy():
    """A static element fitted on a gentle passive class-6 run of the memoryless ("static")
    reference: the states a velocity-feedback policy drives it into are outside its data."""
    d = collect_vertical("static", track_class=6, duration=5.0, sample_rate=200.0, seed=3)
    rows = d["t"] >= 0.1
    U, V = d["U"][rows], d["V"][rows]
    return LegendreRegression(degree=(5, 5)).fit(U, V), (U, V)


class Pumping:
    """Positive carbody-velocity feedback (``predict`` interface): excites the body mode."""

    def predict(self, obs, deterministic=True):
        return np.array([np.clip(8.0 * obs[3], -1.0, 1.0)]), None


def test_held_out_error_falls_after_refinement(toy):
    model, data = toy
    lines = []
    options = RefineOptions(duration=5.0, n_tracks=1, n_holdout=2, n_add=200)
    kw = dict(data=data, reference="static", options=options)
    refined, hist = refine(model, Pumping(), rounds=2, log=lines.append, **kw)
    assert [h["round"] for h in hist] == [0, 1, 2] and len(lines) == 3
    assert hist[-1]["error"] < 0.5 * hist[0]["error"]  # measured 247 % → 36 %
    assert hist[-1]["ood"] < hist[0]["ood"]
    assert hist[-1]["n_samples"] == data[1].size + 2 * 200
    assert refined.degree == model.degree and refined is not model
    # a plain callable obs -> action is the same policy; seeded runs reproduce exactly
    again, hist2 = refine(model, lambda o: np.clip(8.0 * o[3], -1, 1), rounds=2, log=None, **kw)
    assert hist2 == hist
    U = data[0]
    np.testing.assert_array_equal(again.predict(U), refined.predict(U))


def test_refine_bad_arguments(toy):
    model, data = toy
    with pytest.raises(ValueError, match="rounds"):
        refine(model, Pumping(), rounds=-1, data=data)
    with pytest.raises(ValueError, match="reference"):
        refine(model, Pumping(), rounds=0, data=data, reference="linear")
    with pytest.raises(ValueError, match="non-finite action"):
        short = RefineOptions(duration=1.0)
        refine(model, lambda o: np.nan, rounds=0, data=data, reference="static", options=short)
    for field, bad in (("n_tracks", 0), ("n_holdout", 1.5), ("n_add", -3), ("speed", -1.0)):
        with pytest.raises(ValueError, match=field):
            RefineOptions(**{field: bad})
    with pytest.raises(ValueError, match="control_dt"):
        refine(model, Pumping(), rounds=0, data=data, options=RefineOptions(control_dt=1e-6))


def test_refine_command_writes_a_loadable_element_and_refuses_to_overwrite(tmp_path, capsys):
    from agents.commands.cli import main
    from railgym.envs.vertical.env import VerticalSuspensionEnv
    from surrogates import io
    from surrogates.memory import element_form

    out = tmp_path / "refined.json"
    argv = ["refine", "lqr", "--rounds", "1", "--duration", "2", "--tracks", "1", "--add", "50"]
    assert main([*argv, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "round 0:" in text and "round 1:" in text
    model = io.load(out)
    assert element_form(model.features_).form == "maxwell"
    env = VerticalSuspensionEnv(surrogate=out, duration=0.5)
    env.reset(seed=0)
    assert main([*argv, "--out", str(out)]) == 2
    assert "overwrite" in capsys.readouterr().err
