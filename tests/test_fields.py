"""Field readers: NASTRAN number forms, integers, component codes, and writing reals back."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from femcal.deck.fields import (
    BadField,
    format_real,
    parse_components,
    parse_int,
    parse_number,
    parse_real,
)


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("1.5", 1.5),
        ("1.", 1.0),
        (".5", 0.5),
        ("-.5", -0.5),
        ("+2.", 2.0),
        ("1.-3", 1e-3),
        ("-.5+2", -50.0),
        ("7.85-9", 7.85e-9),
        ("1.E+3", 1000.0),
        ("1.E3", 1000.0),
        ("1.5E-3", 1.5e-3),
        ("1D3", 1000.0),
        ("1.5D-2", 0.015),
        ("1E3", 1000.0),
        ("2.1+5", 210000.0),
        ("0.", 0.0),
        ("-0.", -0.0),
    ],
)
def test_real_forms(text, value):
    assert parse_real(text) == value


@pytest.mark.parametrize(
    "text", ["7", "-12", "1_000.", "INF", "NAN", "1.2.3", "1.5E", "E5", "A", "1-3", "."]
)
def test_bad_reals(text):
    with pytest.raises(BadField):
        parse_real(text)


def test_integer_in_real_field_says_so():
    with pytest.raises(BadField, match="decimal point"):
        parse_real("7")


@pytest.mark.parametrize(("text", "value"), [("0", 0), ("12", 12), ("-3", -3), ("+4", 4)])
def test_ints(text, value):
    assert parse_int(text) == value


@pytest.mark.parametrize("text", ["1.", "1.0", "1E3", "1_0", "A", "٣", "+", "-"])
def test_bad_ints(text):
    with pytest.raises(BadField):
        parse_int(text)


def test_number_accepts_both():
    assert parse_number("3") == 3 and isinstance(parse_number("3"), int)
    assert parse_number("3.") == 3.0


@pytest.mark.parametrize(("text", "value"), [("123456", 123456), ("0", 0), ("531", 135), ("6", 6)])
def test_components(text, value):
    assert parse_components(text) == value


@pytest.mark.parametrize("text", ["7", "112", "1.", "12a", "00"])
def test_bad_components(text):
    with pytest.raises(BadField):
        parse_components(text)


@given(st.floats(allow_nan=False, allow_infinity=False, width=64))
def test_format_real_round_trips_or_keeps_most_digits(x):
    s = format_real(x, 16)
    assert len(s) <= 16
    y = parse_real(s)
    if len(_shortest(x)) <= 16:
        assert y == x
    elif 1e-9 < abs(x) < 1e9:
        assert math.isclose(y, x, rel_tol=1e-11)  # at least 12 significant digits
    elif 1e-99 < abs(x) < 1e99:
        assert math.isclose(y, x, rel_tol=1e-10)  # 2-digit exponents leave 11 digits
    else:
        assert math.isclose(y, x, rel_tol=1e-8) or abs(x) < 1e-300  # 3-digit: 9 digits


def _shortest(x):
    from femcal.deck.fields import _compact

    return _compact(repr(x))


@given(st.from_regex(r"\A-?\d{1,4}\.\d{0,6}\Z"))
def test_small_field_texts_written_back_exactly(text):
    x = parse_real(text)
    assert parse_real(format_real(x, 16)) == x
    assert len(format_real(x, 16)) <= max(len(text), 3)


def test_format_real_exact_refuses_lossy():
    with pytest.raises(ValueError):
        format_real(1.2345678901, 8, exact=True)
    assert format_real(1e-3, 8) == ".001"
    assert format_real(2.1e5, 8) == "210000."
    assert format_real(7.85e-9, 8) == "7.85-9"
