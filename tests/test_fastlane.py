"""The fast lane changes speed, never results: both lanes read every deck identically."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from femcal.deck import read_deck
from femcal.deck import reader as reader_module
from femcal.errors import DeckError

from .conftest import refdeck_cases

HEAD = "SOL 103\nCEND\nBEGIN BULK\n"


def same_deck(a, b) -> None:
    assert a.card_count == b.card_count
    assert list(a.card_count) == list(b.card_count)  # first-seen order too
    assert a.tables.keys() == b.tables.keys()
    for name, ta in a.tables.items():
        tb = b.tables[name]
        assert np.array_equal(ta.line, tb.line) and np.array_equal(ta.file, tb.file), name
        for col, x in ta.columns.items():
            y = tb.columns[col]
            if x.dtype == object:
                assert list(x) == list(y), (name, col)
            else:
                assert x.dtype == y.dtype, (name, col)
                assert np.array_equal(x, y, equal_nan=True), (name, col)
                assert np.array_equal(np.signbit(x), np.signbit(y)) if x.dtype.kind == "f" else True
    assert {k: v.items for k, v in a.records.items()} == {k: v.items for k, v in b.records.items()}
    assert a.unused.items == b.unused.items


def read_both(path):
    results = []
    for fast in (True, False):
        try:
            results.append(read_deck(path, fast_lane=fast))
        except DeckError as e:
            results.append([str(i) for i in e.issues])
    return results


@pytest.mark.parametrize(
    ("name", "main", "ref"), refdeck_cases(), ids=[c[0] for c in refdeck_cases()]
)
def test_reference_decks_read_the_same_in_both_lanes(name, main, ref):
    fast, slow = read_both(main)
    same_deck(fast, slow)


def test_blocks_split_cards_and_includes_keep_order(write, monkeypatch):
    # Tiny blocks: cards and their continuations straddle block boundaries.
    monkeypatch.setattr(reader_module, "BLOCK_LINES", 3)
    write(
        "GRID    5               5.\nCBAR    9       1       5       6       0.      0.      1.\n"
        "+       12\nGRID    6\n",
        "inc.bdf",
    )
    text = HEAD + "".join(f"GRID    {i:<8}        {i}.\n" for i in range(1, 5))
    text += "CBAR    1       1       1       2       0.      0.      1.\n"
    text += "$ comment between a card and its continuation\n+       12\n"
    text += "INCLUDE 'inc.bdf'\nGRID    7\nENDDATA\nGRID    8\n"
    fast, slow = read_both(write(text))
    same_deck(fast, slow)
    assert fast.table("GRID")["id"].tolist() == [1, 2, 3, 4, 5, 6, 7]
    assert fast.table("CBAR")["pa"].tolist() == [12, 12]


fields8 = st.sampled_from(
    [
        "",
        "1",
        "12",
        "-3",
        "1.5",
        "-.5+2",
        "7.85-9",
        "1.E3",
        "1D3",
        "7",
        "x",
        "1_0",
        "123456",
        "0",
        "531",
        "GGG",
        "1 2",
        ".",
        "1.-",
        "+",
        "2.5E+1",
    ]
)
wide_fields = st.one_of(
    fields8,
    st.sampled_from([
        "2.4390243902439024", "-0.30000000000000004", "1.7976931348623157E+308",
        "123456789", "12345678901234567", "-1.234567890123-5", " 12.5 ", "1.0 2",
        "7.85E-09", "1.5D+03", "0.", "  ", "123456", "x" * 33, "1." + "0" * 30, "1." + "0" * 29,
        "\r1.", "2.\x0c", "1.E400",
    ]),
    st.text(alphabet="0123456789.+-E ", min_size=0, max_size=34),
)  # fmt: skip
names = st.sampled_from(
    [
        "GRID",
        "CQUAD4",
        "CTRIA3",
        "CBAR",
        "CROD",
        "CONM2",
        "PSHELL",
        "MAT1",
        "CELAS1",
        "PROD",
        "CHEXA",
        "FORCE",
        "RBE2",
        "SPC1",
        "PARAM",
    ]
)


@st.composite
def lines(draw):
    name = draw(names)
    vals = draw(st.lists(fields8, min_size=0, max_size=8))
    line = f"{name:<8}" + "".join(f"{v:>8}" if draw(st.booleans()) else f"{v:<8}" for v in vals)
    kind = draw(st.sampled_from(["card", "card", "card", "cont", "comment", "blank", "free",
                                 "free", "free cont", "free long", "free wide",
                                 "free wide"]))  # fmt: skip
    if kind == "cont":
        line = "+" + line[1:8].replace(name[1:], " " * (len(name) - 1)) + line[8:]
    elif kind == "comment":
        line = "$ " + line
    elif kind == "blank":
        line = ""
    elif kind == "free":  # free field, fields padded or not, name in any case
        pad = draw(st.booleans())
        line = ",".join([draw(st.sampled_from([name, name.lower(), f" {name}"]))]
                        + [f" {v} " if pad else v for v in vals])  # fmt: skip
    elif kind == "free cont":
        line = ",".join(["+", *vals])
    elif kind == "free long":  # a field too long for small field, or a continuation field
        line = ",".join([name, *vals, "1.23456789"] if vals else [name, *([""] * 8), "+C"])
    elif kind == "free wide":  # free fields of any length, spaces around and inside
        wide = draw(st.lists(wide_fields, min_size=0, max_size=9))
        head = draw(st.sampled_from([name, f" {name} ", name.lower(), f"{name}*", "+", "",
                                     "LONGNAME9", "*" + name]))  # fmt: skip
        line = ",".join([head, *wide])
    return line


@settings(max_examples=400, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(lines(), min_size=1, max_size=25), st.integers(min_value=1, max_value=6))
def test_random_decks_read_the_same_in_both_lanes(write, monkeypatch, body, block):
    monkeypatch.setattr(reader_module, "BLOCK_LINES", block)
    fast, slow = read_both(write(HEAD + "\n".join(body) + "\n"))
    if isinstance(fast, list) or isinstance(slow, list):
        assert fast == slow  # the same problems, in the same words
    else:
        same_deck(fast, slow)


def test_free_field_cards_with_long_fields_take_the_fast_lane(write):
    """Free-field lines of any field length up to FREE_WIDTH, spaces around the fields and
    names in any case, are read with NumPy (the field-by-field reader gets none of them),
    to the values the field-by-field reader reads; longer fields, a name of 9 characters, a
    tab or a continuation field leave their line to it."""
    from femcal.deck.fastlane import FREE_WIDTH, split_block
    from femcal.deck.reader import FAST_LAYOUTS

    body = ["GRID,1,,2.4390243902439024,-0.30000000000000004,1.7976931348623157E+308",
            " grid , 2 ,0, 1.5D+03 ,7.85-9,  0.",
            "CQUAD4,1,1,1,2,3,4",
            "GRID,3,,1.," + "2." + "0" * (FREE_WIDTH - 2) + ",3.",  # FREE_WIDTH characters
            "GRID,4,,1.," + "2." + "0" * (FREE_WIDTH - 1) + ",3.",  # one more
            "GRID,5,,1.,2.,3.,,,,+C",
            "GRID,6\t,,1.,2.,3.",
            "LONGNAME9,1,2"]  # fmt: skip
    split = split_block(body, True, FAST_LAYOUTS)
    assert sorted(split.slow.tolist()) == [4, 5, 6, 7]
    assert sorted(g.name for g in split.groups) == ["CQUAD4", "GRID"]
    grid = next(g for g in split.groups if g.name == "GRID")
    assert grid.lines.tolist() == [0, 1, 3]
    path = write(HEAD + "\n".join(body[:4]) + "\n")
    fast, slow = read_both(path)
    same_deck(fast, slow)
    xyz = fast.table("GRID")
    assert xyz["x2"][0] == -0.30000000000000004 and xyz["x1"][1] == 1500.0
    assert xyz["x3"][0] == 1.7976931348623157e308 and xyz["x2"][1] == 7.85e-9


def test_a_nul_byte_at_a_fields_end_is_read_as_the_field_reader_reads_it(write):
    """NumPy's byte strings drop a NUL at a field's end, the field-by-field reader keeps it
    (and says the field is not a number): such a line is left to that reader, small field
    or free."""
    for line in ("GRID          1\x00", "PSHELL        1\x00        1.7976930       1.000000",
                 "CONM2   11111111      1\x00", "GRID,1,,1.\x00,2.,3."):  # fmt: skip
        fast, slow = read_both(write(HEAD + line + "\n"))
        assert isinstance(fast, list) and fast == slow, line


def test_integers_at_the_int64_limit_and_enddata_behind_white_space(write):
    """Both lanes refuse -2^63 (the field reader's limit is a magnitude below 2^63) and read
    2^63 - 1; ENDDATA behind a form feed or another white space that a strip removes ends
    the bulk data in both, ENDDATA in field 2 in neither."""
    for body in ("GRID,-9223372036854775808,,1.,2.,3.",
                 "GRID,9223372036854775807,,1.,2.,3.",
                 "GRID,1,,1.,2.,3.\n\x0cENDDATA,\nGRID,2,,1.,2.,3.",
                 "GRID,1,,1.,2.,3.\n\x0cENDDATA\nGRID,2,,1.,2.,3.",
                 "GRID,1,,1.,2.,3.\n\xa0ENDDATA,\nGRID,2,,1.,2.,3.",
                 "GRID    1               1.      2.      3.\n        ENDDATA\n"
                 "GRID,2,,1.,2.,3."):  # fmt: skip
        fast, slow = read_both(write(HEAD + body + "\n"))
        if isinstance(fast, list) or isinstance(slow, list):
            assert fast == slow, body
        else:
            same_deck(fast, slow)
    fast, _ = read_both(write(HEAD + "GRID,1,,1.,2.,3.\n\x0cENDDATA,\nGRID,2,,1.,2.,3.\n"))
    assert fast.table("GRID")["id"].tolist() == [1]


def test_cards_are_counted_in_the_order_first_seen(write):
    """A card read field by field before one of its name that the fast lane read in the same
    block sets the first-seen order (the fast lane's groups are stored first)."""
    body = ("GRID*   3                               2.              0.\n*       0.\n"
            "CONM2   1       1               1.\n"
            "GRID    1               0.      0.      0.\n")
    fast, slow = read_both(write(HEAD + body))
    same_deck(fast, slow)
    assert list(fast.card_count) == ["GRID", "CONM2"]
