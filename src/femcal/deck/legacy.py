"""Older field conventions that NASTRAN still reads, turned into their current form before a
card's fields are typed by its layout (:mod:`femcal.deck.cards`).

CBAR, CBEAM, BAROR and BEAMOR field 9 (OFFT) is the one such field femcal meets in old
decks:

* **The old orientation flag F.** Before OFFT, field 9 of CBAR and BAROR held an integer that
  said what fields 6-8 are: ``1`` a vector X1-X3, ``2`` a grid G0 in field 6 with fields 7 and 8
  blank or zero (NASTRAN User's Manual, COSMIC NASTRAN-95, CBAR and BAROR; the input checks
  of IFS1P, ``mis/ifs1p.f``). Those vectors and offsets are in the displacement systems of the
  end grids, which is OFFT ``GGG``, so a flag that agrees with field 6 reads as ``GGG``, and
  zeros in fields 7-8 beside F = 2 as blanks. MSC's GEOM2 tables keep this flag for CBAR and
  CBEAM alike (DMAP Programmer's Guide, GEOM2 CBAR and CBEAM records, word F), so BEAMOR and
  CBEAM read it too. A flag that contradicts field 6 (F = 1 beside an integer G0, F = 2 beside a
  real X1), any other integer, and non-zero fields 7-8 beside F = 2 are errors, as IFS1P
  rejects them. A flag beside a blank field 6 is read as ``GGG`` too: the orientation then
  comes from BAROR/BEAMOR, whose own field 6 says unambiguously what it is.
* **The obsolete offset code E.** The Quick Reference Guide's OFFT table notes that ``O`` (an
  end offset in the element's offset system) replaces the obsolete character ``E``; ``GEG``
  reads as ``GOG``.
* **Any other word** is an error: the Guide allows only the eight codes of its table and calls
  anything else an input error.

Each function takes a card's data fields (stripped, upper case, ``''`` for blank), rewrites
them in place, and returns the problems found as (field index, text, expected).
"""

from __future__ import annotations

from collections.abc import Callable

from .fields import BadField, is_int_text, is_real_text, parse_real

#: The OFFT codes of the Quick Reference Guide: orientation vector in the displacement system
#: of GA (G) or basic (B), then end A's and end B's offset in the displacement system (G) or
#: the element's offset system (O).
OFFT_CODES = ("GGG", "BGG", "GGO", "BGO", "GOG", "BOG", "GOO", "BOO")
_OFFT_SET = frozenset(OFFT_CODES)

#: Data field indices of fields 6-9.
_X1, _X2, _X3, _OFFT = 4, 5, 6, 7

_CODES_TEXT = ", ".join(OFFT_CODES[:-1]) + " or " + OFFT_CODES[-1]
_FLAG_TEXT = "the old orientation flag F: 1 for a vector X1-X3, 2 for a grid G0 in field 6"


def _is_zero(s: str) -> bool:
    """Whether a field reads as zero (integer or real), the blank/0 of the old F = 2 form."""
    if is_int_text(s):
        return int(s) == 0
    try:
        return parse_real(s) == 0.0
    except BadField:
        return False


def offt_field(card: str, fields: list[str]) -> list[tuple[int, str, str]]:
    """Field 9 of CBAR, CBEAM, BAROR or BEAMOR in its current form (see the module docstring).

    A CBEAM real there is BIT, and non-words other than integers are left to the layout,
    which says what it expected.
    """
    if len(fields) <= _OFFT or not fields[_OFFT]:
        return []
    s = fields[_OFFT]
    if is_int_text(s):
        return _old_flag(card, fields, s)
    if not s[0].isalpha():
        return []
    code = s[0] + s[1:].replace("E", "O") if len(s) == 3 else s
    if code not in _OFFT_SET:
        expected = ("an OFFT code: G or B for the orientation vector, then G or O for each "
                    f"end's offset ({_CODES_TEXT})")  # fmt: skip
        return [(_OFFT, s, expected)]
    fields[_OFFT] = code
    return []


def _old_flag(card: str, fields: list[str], s: str) -> list[tuple[int, str, str]]:
    """The integer flag F of field 9: checked against field 6 and read as ``GGG``."""
    flag = int(s)
    if flag not in (1, 2):
        return [(_OFFT, s, f"an OFFT code ({_CODES_TEXT}) or {_FLAG_TEXT}")]
    which = f"{card} {fields[0]}" if fields[0] else card  # BAROR and BEAMOR have no id
    x1 = fields[_X1]
    if flag == 1 and is_int_text(x1):
        return [(_OFFT, s, f"2, the old orientation flag for a grid G0 ({which} gives G0 = {x1} "
                           "in field 6; F = 1 is for a vector X1-X3), or an OFFT code such as "
                           "GGG")]  # fmt: skip
    if flag == 2 and is_real_text(x1):
        return [(_OFFT, s, f"1, the old orientation flag for a vector X1-X3 ({which} gives "
                           f"X1 = {x1} in field 6; F = 2 is for a grid G0), or an OFFT code "
                           "such as GGG")]  # fmt: skip
    errors = []
    if flag == 2:  # fields 7 and 8: blank or zero beside G0
        for k in (_X2, _X3):
            if k >= len(fields) or not fields[k]:
                continue
            if _is_zero(fields[k]):
                fields[k] = ""
            else:
                errors.append((k, fields[k], "blank or 0 (the old orientation flag F = 2 "
                                             "orients by the grid G0 alone)"))  # fmt: skip
    fields[_OFFT] = "GGG"
    return errors


#: Card name -> the rewrite of its fields into their current form.
FIELD_REWRITES: dict[str, Callable[[str, list[str]], list[tuple[int, str, str]]]] = {
    name: offt_field for name in ("CBAR", "CBEAM", "BAROR", "BEAMOR")
}
