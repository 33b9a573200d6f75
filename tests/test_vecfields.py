"""The vectorised field readers agree with the field-by-field readers."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from femcal.deck.fields import BadField, parse_int, parse_real
from femcal.deck.vecfields import read_ints, read_reals


def as_matrix(texts: list[str], width: int = 8) -> np.ndarray:
    """A uint64 field column holding the 8-byte texts (width kept for call compatibility)."""
    raw = b"".join(t.encode("latin-1").ljust(8)[:8] for t in texts)
    return np.frombuffer(raw, np.uint64).copy()


def python(fn, text: str):
    s = text.strip()
    if not s or " " in s:
        return None
    try:
        return fn(s)
    except BadField:
        return None


COMMON_REALS = ["1.5", "1.", ".5", "-.5", "+2.", "1.-3", "-.5+2", "7.85-9", "1.E+3", "1.E3",
                "1.5E-3", "1D3", "1.5D-2", "1E3", "2.1+5", "0.", "-0.", "  3.25  ", "   -12.5"]


def test_common_reals_take_the_fast_path_with_exact_values():
    F = as_matrix(COMMON_REALS)
    values, ok, blank = read_reals(F)
    assert ok.all() and not blank.any()
    for t, v in zip(COMMON_REALS, values, strict=True):
        expected = parse_real(t.strip())
        assert v == expected and np.signbit(v) == np.signbit(expected), t


def test_ints_and_blanks():
    F = as_matrix(["12", " -7", "+0", "", "1.5", "1 2", "-", "1_0"])  # 1_0: int() takes it
    values, ok, blank = read_ints(F)
    assert values[:3].tolist() == [12, -7, 0]
    assert ok.tolist() == [True, True, True, False, False, False, False, False]
    assert blank.tolist() == [False, False, False, True, False, False, False, False]


alphabet = st.sampled_from([*"0123456789+-.EDX ", "1", "2", "5", "."])
texts = st.lists(alphabet, min_size=0, max_size=8).map("".join)


@settings(max_examples=500)
@given(st.lists(texts, min_size=1, max_size=20))
def test_vector_reals_never_disagree_with_parse_real(batch):
    values, ok, blank = read_reals(as_matrix(batch, 8))
    for t, v, good, b in zip(batch, values, ok, blank, strict=True):
        assert b == (t.strip() == "")
        if good:
            assert python(parse_real, t) == v, t


@settings(max_examples=400)
@given(st.lists(texts, min_size=1, max_size=20))
def test_vector_ints_never_disagree_with_parse_int(batch):
    values, ok, _ = read_ints(as_matrix(batch, 8))
    for t, v, good in zip(batch, values, ok, strict=True):
        if good:
            assert python(parse_int, t) == v, t
        elif python(parse_int, t) is not None:
            raise AssertionError(f"valid integer {t!r} not read by the vector reader")


@settings(max_examples=400)
@given(st.floats(min_value=-1e6, max_value=1e6, allow_nan=False).map(lambda x: f"{x:.4g}"))
def test_printed_floats_are_read_exactly(text):
    mant, _, exp = text.upper().partition("E")
    mant = mant if "." in mant else mant + "."
    text = mant + (f"{int(exp):+d}" if exp else "")  # NASTRAN's short form: 5.+5, 1.25-3
    if len(text) > 8:
        return
    values, ok, _ = read_reals(as_matrix([text]))
    assert ok[0] and values[0] == parse_real(text), text
