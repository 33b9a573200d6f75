"""Property-based tests: one card in small, large and free field reads to the same values;
garbage never raises anything but DeckError."""

from __future__ import annotations

import contextlib

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from femcal.deck import read_deck
from femcal.deck.cards import CARDS
from femcal.errors import DeckError, ModelError
from femcal.model.build import build_model

HEAD = "SOL 103\nCEND\nBEGIN BULK\n"
CARD_NAMES = [
    "GRID",
    "CQUAD4",
    "CTRIA3",
    "CBAR",
    "CBEAM",
    "PSHELL",
    "PBAR",
    "MAT1",
    "CONM2",
    "CHEXA",
    "CELAS2",
    "RBAR",
    "CORD2R",
    "MAT8",
    "CBUSH",
    "PSOLID",
]

ints = st.integers(min_value=1, max_value=9_999_999).map(str)


@st.composite
def reals(draw) -> str:
    """A NASTRAN real of at most 8 characters in one of its written forms."""
    mant = draw(st.integers(min_value=0, max_value=9999))
    point = draw(st.integers(min_value=0, max_value=len(str(mant))))
    digits = str(mant)
    text = digits[:point] + "." + digits[point:]
    sign = draw(st.sampled_from(["", "-", "+"]))
    exp = draw(st.sampled_from(["", "E3", "E-2", "+1", "-4", "D2"]))
    out = sign + text + exp
    return out if len(out) <= 8 and any(c.isdigit() for c in text) else "1."


def field_text(kind: str, draw) -> str:
    if kind == "I":
        return draw(ints)
    if kind in ("R", "N"):
        return draw(reals())
    if kind == "C":
        return "".join(sorted(draw(st.sets(st.sampled_from("123456"), min_size=1))))
    return "GGG"


@st.composite
def cards(draw):
    name = draw(st.sampled_from(CARD_NAMES))
    layout = CARDS[name].layout
    values = []
    for slot in layout.slots:
        if not slot.columns:
            values.append("")
            continue
        c = slot.columns[draw(st.integers(0, len(slot.columns) - 1))]
        if c.name == "offt":
            values.append(draw(st.sampled_from(["GGG", "GOO", "BGG"])))
            continue
        blank_ok = not c.required
        if blank_ok and draw(st.booleans()):
            values.append("")
        else:
            values.append(field_text(c.kind, draw))
    while values and not values[-1]:
        values.pop()
    return name, values


def small(name: str, vals: list[str], justify: str) -> str:
    lines = []
    for r in range(0, max(len(vals), 1), 8):
        head = name if r == 0 else "+"
        lines.append(f"{head:<8}" + "".join(f"{v:{justify}8}" for v in vals[r : r + 8]))
    return "\n".join(lines)


def large(name: str, vals: list[str], justify: str) -> str:
    lines = []
    for r in range(0, max(len(vals), 1), 4):
        head = name + "*" if r == 0 else "*"
        lines.append(f"{head:<8}" + "".join(f"{v:{justify}16}" for v in vals[r : r + 4]))
    return "\n".join(lines)


def free(name: str, vals: list[str]) -> str:
    lines = []
    for r in range(0, max(len(vals), 1), 8):
        lines.append(",".join([name if r == 0 else "", *vals[r : r + 8]]))
    return "\n".join(lines)


@settings(max_examples=150, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cards(), st.sampled_from(["<", ">"]), st.booleans())
def test_small_large_free_read_the_same(write, card, justify, lower):
    name, vals = card
    texts = [small(name, vals, justify), large(name, vals, justify), free(name, vals)]
    if lower:
        texts = [t.lower() for t in texts]
    tables = []
    for i, t in enumerate(texts):
        d = read_deck(write(HEAD + t + "\nENDDATA\n", f"f{i}.bdf"))
        tables.append(d.table(name).columns)
    for other in tables[1:]:
        for k, v in tables[0].items():
            if v.dtype == object:
                assert list(v) == list(other[k]), k
            else:
                assert np.array_equal(v, other[k], equal_nan=True), k


garbage = st.text(
    alphabet=st.characters(codec="latin-1", exclude_categories=("Cs",)), max_size=120
).map(lambda s: s.replace("\r", " ").replace("\x0b", " ").replace("\x0c", " "))


@settings(max_examples=300, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(garbage, min_size=1, max_size=6))
def test_garbage_gives_deck_error_or_a_deck(write, lines):
    path = write(HEAD + "\n".join(lines) + "\n")
    try:
        deck = read_deck(path)
    except DeckError:
        return
    with contextlib.suppress(ModelError):
        build_model(deck)


@settings(max_examples=200, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.sampled_from(CARD_NAMES),
    st.lists(garbage, min_size=1, max_size=3),
    st.sampled_from(["small", "free"]),
)
def test_known_card_with_junk_fields_gives_deck_error(write, name, junk, fmt):
    # Junk that is certainly not an integer, in the card's first field (always an integer
    # id, or a blank-only field), makes the card invalid whatever else is there.
    first = "x" + junk[0].replace(",", "").replace("$", "").replace("\t", "")[:6]
    rest = [j.replace(",", "").replace("$", "").replace("\t", "")[:8] for j in junk[1:]]
    vals = [first.strip() or "x", *rest]
    text = small(name, vals, "<") if fmt == "small" else free(name, vals)
    try:
        read_deck(write(HEAD + text + "\n"))
    except DeckError as e:
        assert e.issues and all(i.file.endswith("deck.bdf") and i.line >= 4 for i in e.issues)
    else:
        raise AssertionError("junk card was accepted")
