import numpy as np
import pytest

from agents.evaluate import evaluate, evaluate_crash, format_rows, load_policy


def test_evaluate_vertical_skyhook_beats_passive_on_the_same_tracks():
    rows = evaluate(["passive", "skyhook"], backend="linear", track_classes=(6,), episodes=2)
    by = {r["policy"]: r for r in rows}
    assert by["passive"]["a_w_reduction_%"] == 0.0
    assert by["skyhook"]["a_w"] < by["passive"]["a_w"]
    expected = 100 * (1 - by["skyhook"]["a_w"] / by["passive"]["a_w"])
    assert by["skyhook"]["a_w_reduction_%"] == pytest.approx(expected)
    assert all(np.isfinite(r["wz"]) and r["wz"] > 0 for r in rows)
    assert "skyhook" in format_rows(rows)


def test_evaluate_crash_passive_row():
    (row,) = evaluate_crash(["passive"], backend="surrogate", speeds_kmh=(40.0,))
    assert len(row["peak_decel_g"]) == 2 and np.all(np.asarray(row["peak_decel_g"]) > 1.0)
    assert row["peak_reduction_%"] == 0.0


def test_unknown_policy_is_a_clear_error():
    with pytest.raises(ValueError, match="policy must be one of"):
        load_policy("skyhook2")
