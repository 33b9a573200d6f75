"""Write a :class:`Deck` back to NASTRAN text.

Large field by default: 16-character fields hold every value read from a deck exactly
(Python's shortest round-trip text), so read -> write -> read gives identical model arrays.
Values computed by femcal that need more than 16 characters are written with the most
significant digits that fit (about 15). The file is written to a temporary name and renamed,
so a failed write never leaves half a deck.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Literal

from ..atomic import write_lines
from .deck import Deck
from .fields import format_value

FieldFormat = Literal["large", "small", "free"]


def format_card(name: str, values: list, *, field_format: FieldFormat = "large") -> list[str]:
    """Lines of one card. ``values`` are data fields (None for blank), 8 per logical line.

    Falls back to free field when a value does not fit the chosen width (for example a
    free-field text longer than 16 characters in a card femcal does not interpret).
    """
    while values and values[-1] is None:
        values = values[:-1]
    if field_format == "small":
        # Small field only where every value fits 8 characters exactly; else large field.
        try:
            texts = [format_value(v, 8, exact=True) for v in values]
        except ValueError:
            return format_card(name, values, field_format="large")
        return list(_fixed_lines(name, texts, 8))
    if field_format == "large":
        try:
            texts = [format_value(v, 16) for v in values]
        except ValueError:
            return format_card(name, values, field_format="free")
        return list(_fixed_lines(name, texts, 16))
    texts = [format_value(v, 10**6) for v in values]
    lines = []
    for r in range(0, max(len(texts), 1), 8):
        head = name if r == 0 else ""
        lines.append(",".join([head, *texts[r : r + 8]]))
    return lines


def _fixed_lines(name: str, texts: list[str], width: int) -> Iterator[str]:
    per_line = 64 // width
    if width == 16:
        head, cont = f"{name + '*':<8}", "*       "
    else:
        head, cont = f"{name:<8}", "+       "
    if not texts:
        yield head.rstrip()
        return
    for r in range(0, len(texts), per_line):
        chunk = texts[r : r + per_line]
        line = (head if r == 0 else cont) + "".join(
            f"{t:>{width}}" if _numeric(t) else f"{t:<{width}}" for t in chunk
        )
        yield line.rstrip()


def _numeric(t: str) -> bool:
    return bool(t) and (t[0].isdigit() or t[0] in "+-.")


def iter_cards(deck: Deck) -> Iterator[tuple[str, list]]:
    """(card name, field values) for every card of the deck, grouped by name in first-seen order."""
    unused: dict[str, list] = {}
    for card in deck.unused:
        unused.setdefault(card.name, []).append(card)
    for name in deck.card_count:
        if name in deck.tables:
            table = deck.tables[name]
            layout = table.layout
            for row in table.rows():
                yield name, layout.unparse(row)
        elif name in deck.records:
            for r in deck.records[name]:
                yield name, r.to_fields()
        elif name in unused:
            for r in unused[name]:
                yield name, r.to_fields()


def deck_lines(deck: Deck, *, field_format: FieldFormat = "large") -> Iterator[str]:
    """All lines of the deck as text (without newlines)."""
    if deck.executive or deck.sol is not None or deck.has_bulk_section:
        yield from deck.executive
        yield "CEND"
        yield from deck.case.lines
        yield "BEGIN BULK"
    for name, values in iter_cards(deck):
        yield from format_card(name, values, field_format=field_format)
    yield "ENDDATA"


def write_deck(
    deck: Deck, path: str | os.PathLike[str], *, field_format: FieldFormat = "large"
) -> Path:
    """Write ``deck`` to ``path`` (atomically: temporary file, then rename). Returns the path."""
    path = Path(path)
    return write_lines(path, deck_lines(deck, field_format=field_format), encoding="latin-1")
