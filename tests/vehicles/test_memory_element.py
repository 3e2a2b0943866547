"""The memory element the data ask for (railgym.vehicles.memory_element): on a synthetic
nonlinear standard-linear-solid law with a known time constant, inside and outside the old
grid (4, 8, 16 ms), the chosen τ is within 20 % of the true one; a τ at the edge of the
search warns with the flag that widens it; the number of memory states follows the data;
bad ``--tau`` / ``--memory-states`` values exit 2 naming the flag."""

import numpy as np
import pytest

from agents.commands.collect import main as collect_main
from railgym.vehicles.collect import save_vertical_surrogate
from railgym.vehicles.memory_element import (
    MEMORY_DEGREES,
    PRODUCT_FLOOR,
    WIDEN_LIMIT,
    build_memory_surrogate,
    widen_degrees,
)
from surrogates import io
from surrogates.selection import SelectionResult
from tests.surrogates.test_tau_search import sls_runs

DEGREES = [(3, 3, 3), (3, 3, 5), (5, 5, 5)]
K3 = 2.0e7  # N/m³, progressive term of the static spring


def nonlinear_data(tau, memory=True, seed=0, coupling=0.0, noise=0.0):
    """``collect_design``-like data (full-length ``force``) of a progressive spring
    ``K3·δ³`` added to the standard linear solid of :func:`sls_runs` (``memory=False``: a
    spring and a dashpot only, no memory); ``coupling`` (N/m²) adds a term in ``δ·ζ`` (a
    pressure that depends on the deflection and the gas state together), ``noise`` (N) a
    seeded white measurement noise."""
    runs = []
    rng = np.random.default_rng(seed + 100)
    for r in sls_runs(tau, seed=seed):
        d, dd = r["delta"], r["delta_dot"]
        force = r["full"] if memory else 3.6e5 * d + 8.0e3 * dd
        zeta = (r["full"] - 500.0 - 3.6e5 * d - 2.0e3 * dd) / 4.7e5  # the law's own state
        force = force + K3 * d**3 + coupling * d * zeta + noise * rng.standard_normal(d.size)
        runs.append({**r, "force": force})
    return {"runs": runs}


def build(data, **kw):
    return build_memory_surrogate(
        data=data, degrees=DEGREES, known_physics=(), vehicle="manchester", **kw
    )


@pytest.mark.parametrize("tau", [10e-3, 64e-3, 150e-3])
def test_chosen_tau_is_the_laws_inside_and_outside_the_old_grid(tau):
    model, sel, _ = build(nonlinear_data(tau))
    assert sel.states == 1 and "from the data" in sel.decision
    assert sel.best[0] == pytest.approx(tau, rel=0.2)
    assert model.features_ == {"form": "maxwell", "tau": sel.best[0], "known_physics": []}
    assert sel.guess.tau == pytest.approx(tau, rel=0.2)
    assert sel.warnings == []
    # the memory state removes almost all of the memoryless form's error
    assert min(r["rms"] for r in sel.table) < 0.1 * sel.static["rms"]
    assert "memory states: 1" in sel.format()


def test_a_tau_at_the_edge_of_the_range_warns_with_the_flag():
    with pytest.warns(UserWarning, match=r"--tau LO HI"):
        _, sel, _ = build(nonlinear_data(150e-3), tau=(2e-3, 0.05))
    assert sel.best[0] == pytest.approx(0.05, rel=0.06)
    assert "upper end" in sel.warnings[0] and "--tau" in sel.format()
    with pytest.warns(UserWarning, match="--tau"):  # values: the largest one wins
        _, sel, _ = build(nonlinear_data(64e-3), tau=[4e-3, 8e-3, 16e-3])
    assert sel.best[0] == 16e-3


def test_a_memoryless_law_gets_a_memoryless_element(tmp_path):
    data = nonlinear_data(64e-3, memory=False)
    model, sel, _ = build(data)
    assert sel.states == 0 and sel.best[0] is None
    assert "memory states: 0 (from the data" in sel.decision
    assert model.features_["form"] == "static" and model.n_features_in_ == 2
    path = save_vertical_surrogate(model, sel, tmp_path / "el.json", "synthetic")
    report = io.load(path).metadata_["report"]
    assert report["memory_states"] == 0 and report["chosen"]["tau"] is None
    # given, the number of states is used as it is (τ then runs to the range's end)
    with pytest.warns(UserWarning, match="--tau"):
        model1, sel1, _ = build(data, memory_states=1)
    assert sel1.states == 1 and sel1.decision == "memory states: 1 (given)"
    assert model1.features_["form"] == "maxwell"


def test_the_coupled_map_is_taken_where_the_data_couple_deflection_and_state():
    """A term in δ·ζ (the bellows pressure of an air spring depends on both) is beyond an
    additive map: with ``coupled=None`` the coupled LPR is scored and taken; an additive law
    keeps the additive (passive) map."""
    model, sel, _ = build(nonlinear_data(64e-3, coupling=1.0e7), coupled=None)
    assert "map: coupled" in sel.decision and model.interactions
    assert sel.coupled["rms"] < 0.5 * min(r["rms"] for r in sel.table)
    assert sel.best == (sel.best[0], sel.coupled["degree"])
    assert sel.best[0] == pytest.approx(64e-3, rel=0.2)
    assert sel.best_result() is sel.coupled_result and "coupled" in sel.format()
    model, sel, _ = build(nonlinear_data(64e-3, noise=200.0), coupled=None)
    assert "map: additive" in sel.decision and not model.interactions
    _, sel, _ = build(nonlinear_data(64e-3, coupling=1.0e7), product=False)  # additive only
    assert sel.coupled is None and sel.product is None and "map:" not in sel.decision


def test_the_product_input_is_taken_by_default_where_the_data_couple_deflection_and_state(
    tmp_path,
):
    """The same δ·ζ term is exactly what the product input of the form "maxwell_product"
    carries: by default it is scored (its own τ search) and taken, with the law's τ, the
    k-fold error a fraction of the additive map's; saved, the report holds its score; on an
    additive law (already within PRODUCT_FLOOR) it is not scored."""
    model, sel, data = build(nonlinear_data(64e-3, coupling=1.0e7))
    assert model.features_["form"] == "maxwell_product" and model.n_features_in_ == 4
    assert "with the product input" in sel.decision and sel.coupled is None
    assert sel.best == (sel.product["tau"], sel.product["degree"])
    assert sel.best[0] == pytest.approx(64e-3, rel=0.2) == model.features_["tau"]
    assert sel.product["rms"] < 0.2 * min(r["rms"] for r in sel.table)
    assert sel.best_result() is sel.product_result and "product (5, 5, 5," in sel.format()
    assert data["U_memory"].shape[1] == 4
    np.testing.assert_array_equal(
        data["U_memory"][:, 3], data["U_memory"][:, 0] * data["U_memory"][:, 2]
    )
    path = save_vertical_surrogate(model, sel, tmp_path / "el.json", "synthetic")
    back = io.load(path)
    assert back.features_["form"] == "maxwell_product" and back.features_["tau"] == sel.best[0]
    assert back.metadata_["report"]["product"]["rms"] == pytest.approx(sel.product["rms"])
    assert back.features_["units"]["(x1-x2)*zeta"] == "m^2"
    model, sel, _ = build(nonlinear_data(64e-3))
    assert min(r["nrms"] for r in sel.table) < PRODUCT_FLOOR and sel.product is None
    assert model.features_["form"] == "maxwell"


@pytest.mark.parametrize(
    "argv, match",
    [
        (["--tau", "0.1", "0.01"], "--tau LO HI: a range needs LO < HI"),
        (["--tau", "-0.01"], "--tau values must be time constants"),
        (["--tau", "0.01", "0.01", "0.02"], "--tau values must be distinct"),
        (["--tau", "abc"], "--tau"),
        (["--memory-states", "2"], "--memory-states"),
        (["--memory-states", "x"], "--memory-states"),
        (["--features", "static", "--tau", "0.01", "0.1"], "--tau, --memory-states"),
        (["--features", "static", "--coupled"], "--coupled: for the k-fold"),
        (["--features", "maxwell", "--memory-states", "0"], "--memory-states 0"),
    ],
)
def test_bad_memory_flags_exit_2_naming_the_flag(argv, match, tmp_path, capsys):
    with pytest.raises(SystemExit) as done:
        collect_main([*argv, "-o", str(tmp_path / "el.json")])
    assert done.value.code == 2
    assert match in capsys.readouterr().err


@pytest.mark.parametrize(
    "kw, match", [({"tau": (0.2, 0.01)}, "tau LO HI"), ({"memory_states": 3}, "memory_states")]
)
def test_the_python_api_checks_tau_and_states_before_any_work(kw, match, tmp_path):
    from railgym.fmu.collect import build_fmu_element

    with pytest.raises(ValueError, match=match):
        build_fmu_element(tmp_path / "no_such_map.yaml", **kw)
    with pytest.raises(ValueError, match=match):
        build_memory_surrogate(data={"runs": []}, **kw)


def _bowl(target):
    """k-fold-like scores of degree tuples: lowest at ``target``, rising with the distance."""

    def score(grid):
        table = [
            {"candidate": g, "rms": 1.0 + float(np.sum((np.subtract(g, target)) ** 2))}
            for g in grid
        ]
        return SelectionResult("kfold", table, min(table, key=lambda r: r["rms"])["candidate"])

    return score


@pytest.mark.parametrize("target", [(14, 30, 20), (12, 26, 26), (16, 16, 20), (14, 14, 18)])
def test_the_default_degree_search_goes_on_past_its_top(target):
    """A winner at the top of the default grid in an input is not the answer: the search
    goes on in that input until the score turns up (the best within WIDEN_LIMIT found)."""
    score = _bowl(target)
    res = widen_degrees(score(list(MEMORY_DEGREES)), score)
    assert res.best == target and res.at_cap() == []
    scored = [r["candidate"] for r in res.table]
    assert len(scored) == len(set(scored))  # nothing scored twice
    if target == (14, 14, 18):  # inside the grid: nothing more scored
        assert len(scored) == len(MEMORY_DEGREES)


def test_the_widened_search_stops_at_its_limit_and_still_flags_the_cap():
    far = (12, WIDEN_LIMIT[1] + 10, 14)
    res = widen_degrees(_bowl(far)(list(MEMORY_DEGREES)), _bowl(far))
    assert res.best == (12, WIDEN_LIMIT[1], 14) and res.at_cap() == [1]
