"""railgym._checks: properties of the number, integer and sequence checks, the YAML
reader and the "name or path" rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from railgym import _checks as val

finite = st.floats(allow_nan=False, allow_infinity=False)
numpy_float = finite.map(np.float64)


@given(st.one_of(finite, numpy_float, st.integers(-(10**300), 10**300)))
def test_positive_accepts_exactly_the_positive_finite_numbers(x):
    if float(x) > 0:
        out = val.positive(x, "a.b")
        assert type(out) is float and out == float(x)
    else:
        with pytest.raises(val.FieldError, match=r"^a\.b must be positive"):
            val.positive(x, "a.b")


@given(st.one_of(st.booleans(), st.text(), st.complex_numbers(), st.none(), st.just(np.True_)))
def test_non_numbers_are_type_errors_naming_the_field(x):
    with pytest.raises(TypeError, match=r"^speed must be a number"):
        val.real(x, "speed")


@pytest.mark.parametrize("x", [math.nan, math.inf, -math.inf, np.float32("nan"), 10**400])
def test_non_finite_is_rejected(x):
    with pytest.raises(ValueError, match="f must be finite"):
        val.real(x, "f")


@given(finite, finite, finite)
def test_in_range_matches_the_interval(x, a, b):
    lo, hi = min(a, b), max(a, b)
    ok = lo <= x <= hi
    if ok:
        assert val.in_range(x, "x", lo, hi) == x
    else:
        with pytest.raises(val.FieldError, match=r"^x must be in \["):
            val.in_range(x, "x", lo, hi)


@given(st.one_of(st.integers(), st.integers(-(2**62), 2**62).map(np.int64)))
def test_integer_round_trip_and_bool_rejection(n):
    assert val.integer(n, "n") == int(n) and type(val.integer(n, "n")) is int
    with pytest.raises(TypeError, match="n must be an integer"):
        val.integer(bool(n % 2), "n")
    with pytest.raises(TypeError, match="n must be an integer"):
        val.integer(float(n), "n")


def test_quantity_checks_finiteness_before_and_range_after_the_conversion():
    f = val.Fields({"mass_t": 1e307, "v_kmh": -40.0, "ok": 36.0}, "scenario")
    with pytest.raises(val.FieldError, match=r"scenario\.mass_t overflows"):
        f.quantity("mass_t", 1e3)
    with pytest.raises(val.FieldError, match=r"scenario\.v_kmh must be in \(0"):
        f.quantity("v_kmh", 1 / 3.6, 0.0, None, lo_open=True)
    assert f.quantity("ok", 1 / 3.6, 0.0, 20.0) == pytest.approx(10.0)
    f.done()
    g = val.Fields({"a": 1, "typo": 2}, "sec")
    g.real("a")
    with pytest.raises(val.FieldError, match=r"unknown field sec\.typo"):
        g.done()
    with pytest.raises(val.FieldError, match=r"sec\.b is missing"):
        g.get("b")


def test_sequence_choice_and_numeric_array():
    assert val.sequence(np.array([1.0, 2.0]), "band", 2) == (1.0, 2.0)
    with pytest.raises(TypeError, match="band must be a sequence"):
        val.sequence("12", "band")
    with pytest.raises(ValueError, match="band must have 2 items"):
        val.sequence([1.0], "band", 2)
    assert val.choice("full", "observation", ["sensors", "full"]) == "full"
    with pytest.raises(ValueError, match="observation must be one of"):
        val.choice(1, "observation", ["sensors", "full"])
    assert val.choice(1, "k", [1, 2]) == 1
    with pytest.raises(ValueError, match="k must be one of"):
        val.choice(True, "k", [1, 2])
    np.testing.assert_array_equal(val.numeric_array([1, 2], "a", (2,)), [1.0, 2.0])
    for bad in ("x", [True], [1j], [None]):
        with pytest.raises(TypeError, match="a must hold real numbers"):
            val.numeric_array(bad, "a")


def test_load_yaml_names_source_and_line():
    with pytest.raises(val.FieldError, match=r"cfg\.yaml is not valid YAML, line 2"):
        val.load_yaml("a: 1\nb: ]\nc: 2\n", "cfg.yaml")
    assert val.load_yaml("a: 1", "x") == {"a": 1}
