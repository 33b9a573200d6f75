"""NASTRAN deck text -> :class:`Deck` (cards with their file:line), and back; a few fields
changed in the deck's own text (:mod:`femcal.deck.edit`).

>>> from femcal.deck import read_deck, write_deck
"""

from .deck import CaseControl, Deck, RecordList
from .edit import DeckEditError, FieldEdit, edit_deck, write_edited_deck
from .reader import read_deck
from .writer import write_deck

__all__ = ["CaseControl", "Deck", "DeckEditError", "FieldEdit", "RecordList", "edit_deck",
           "read_deck", "write_deck", "write_edited_deck"]  # fmt: skip
