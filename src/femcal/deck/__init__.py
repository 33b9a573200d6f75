"""NASTRAN deck text -> :class:`Deck` (cards with their file:line), and back.

>>> from femcal.deck import read_deck, write_deck
"""

from .deck import CaseControl, Deck, RecordList
from .reader import read_deck
from .writer import write_deck

__all__ = ["CaseControl", "Deck", "RecordList", "read_deck", "write_deck"]
