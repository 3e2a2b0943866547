import numpy as np
import pytest

from surrogates.metrics import (
    average_absolute_error,
    average_relative_error,
    far_from_zero,
    paper_error,
    rms_normalised_error,
    timer,
)


def test_eq8_and_eq9_by_hand():
    true = np.array([2.0, -4.0, 10.0])
    pred = np.array([2.2, -3.0, 10.0])
    # eq. 8: (0.1 + 0.25 + 0) / 3 ; eq. 9: (0.2 + 1 + 0) / 3
    assert average_relative_error(pred, true) == pytest.approx(0.35 / 3, rel=1e-14)
    assert average_absolute_error(pred, true) == pytest.approx(1.2 / 3, rel=1e-14)


def test_relative_error_undefined_at_zero():
    with pytest.raises(ValueError, match="zeros"):
        average_relative_error([1.0, 2.0], [0.0, 2.0])


def test_paper_rule_switches_on_outputs_near_zero():
    far = np.array([10.0, 11.0, 9.0])
    near = np.array([10.0, 0.01, -9.0])
    assert far_from_zero(far) and not far_from_zero(near)
    assert paper_error(far + 1.0, far)[1] == "relative"
    val, kind = paper_error(near + 1.0, near)
    assert kind == "absolute" and val == pytest.approx(1.0)


def test_rms_normalised_error():
    t = np.sin(np.linspace(0, 2 * np.pi, 1001))[:-1]
    assert rms_normalised_error(1.1 * t, t) == pytest.approx(0.1, rel=1e-12)
    assert rms_normalised_error(t, t) == 0.0


def test_shape_mismatch_is_an_error():
    with pytest.raises(ValueError, match="pred has 2"):
        average_absolute_error([1.0, 2.0], [1.0, 2.0, 3.0])


def test_timer_measures_positive_time():
    with timer() as t:
        sum(range(10000))
    assert 0 < t["seconds"] < 5
