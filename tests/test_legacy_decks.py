"""Older field conventions NASTRAN still reads (issue 26): each legacy form in a small deck,
read and solved against the same deck written the current way, and the forms NASTRAN rejects
refused with an error that names file:line, card, field and what was expected.

Sources, cited again in each test:

* [UM] COSMIC NASTRAN User's Manual, section 2.4 (NASTRAN-95, ``um/BULK.TXT``): CBAR and
  BAROR field 9 "F, flag to specify the nature of fields 6-8": 1 = X1, X2, X3; 2 = G0 with
  fields 7-8 blank/0 (CBAR), blank (BAROR); "since 1990 the F field is no longer required".
* [IFS1P] NASTRAN-95 ``mis/ifs1p.f``, the CBAR (180) and BAROR (179) input checks: F outside
  1-2 is bad data; F = 1 needs a real or blank field 6; F = 2 needs an integer G0 > 0 (or
  blank) with fields 7-8 zero.
* [DMAP] MSC Nastran DMAP Programmer's Guide, GEOM2 CBAR and CBEAM records: word F,
  orientation vector flag (1 = XYZ option, 2 = grid option) -- MSC keeps the flag for both.
* [QRG] MSC Nastran Quick Reference Guide, BAROR remark 5 (CBAR remark 8): the OFFT codes
  GGG, BGG, GGO, BGO, GOG, BOG, GOO, BOO; "any attempt to specify invalid combinations
  results in a bulk data entry input error"; "the character O in the table replaces the
  obsolete character E".
"""

from __future__ import annotations

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.errors import DeckError
from femcal.model.build import build_model
from femcal.solve.normal_modes import solve_normal_modes

from .test_fastlane import same_deck

HEAD = "SOL 103\nCEND\nMETHOD = 1\nSPC = 1\nBEGIN BULK\n"


def card(*fields: object) -> str:
    """One small-field line: the name, then data fields of 8 characters."""
    return "".join(f"{'' if f is None else f!s:<8}" for f in fields).rstrip() + "\n"


def cantilever(elements: str, *, beam: bool = False, extra: str = "") -> str:
    """Four bars along x from grid 1 (clamped) to 5, every grid's displacement system turned
    30 degrees about x, a section stiffer about one axis than the other and a spring at the
    tip in one direction (so an orientation vector read in the wrong system moves the
    modes), grid 99 off the axis for G0."""
    s = np.sin(np.radians(30.0))
    c = np.cos(np.radians(30.0))
    text = card("CORD2R", 7, 0, 0.0, 0.0, 0.0, 0.0, f"{-s:.6f}", f"{c:.6f}")
    text += card("", 1.0, 0.0, 0.0)
    for g in range(1, 6):
        text += card("GRID", g, None, f"{100.0 * (g - 1)}", 0.0, 0.0, 7)
    text += card("GRID", 99, None, 0.0, 100.0, 50.0)
    text += card("SPC1", 1, 123456, 1, 99)
    text += card("CELAS2", 100, 20.0, 5, 2)
    text += card("MAT1", 1, "2.1+5", None, 0.3, "7.85-9")
    if beam:
        text += card("PBEAML", 1, 1, None, "BAR") + card("", 20.0, 8.0)
    else:
        text += card("PBAR", 1, 1, 160.0, 5333.3, 853.33, 2500.0)
    text += card("EIGRL", 1, None, None, 8)
    return HEAD + text + extra + elements + "ENDDATA\n"


def bars(name: str, orient: list[object], field9: object = None) -> str:
    """Elements 1-4 of ``name`` with fields 6-8 ``orient`` (blank after it) and 9 ``field9``."""
    six_to_eight = [*orient, None, None, None][:3]
    return "".join(card(name, e, 1, e, e + 1, *six_to_eight, field9) for e in range(1, 5))


def eigenvalues(write, text: str, name: str = "deck.bdf") -> np.ndarray:
    modes, _ = solve_normal_modes(build_model(read_deck(write(text, name))))
    return modes.eigenvalues


def errors_of(path) -> list[str]:
    with pytest.raises(DeckError) as e:
        read_deck(path)
    return [str(i) for i in e.value.issues]


# ------------------------------------------------------------------------ read as NASTRAN does


def test_issue_26_cbar_with_old_flag_f1_reads_as_ggg(write):
    """The deck of issue 26: ``CBAR 3 1 3 4 .0 .0 1.0 1``. F = 1 says fields 6-8 are a vector
    [UM, CBAR]; its vectors are in GA's displacement system, OFFT GGG. The modes are those
    of the deck with field 9 blank or GGG, and not those of BGG (the vector in basic)."""
    orient = [".0", ".0", "1.0"]
    old = eigenvalues(write, cantilever(bars("CBAR", orient, 1)), "old.bdf")
    for modern in (None, "GGG"):
        new = eigenvalues(write, cantilever(bars("CBAR", orient, modern)), "new.bdf")
        np.testing.assert_array_equal(old, new)
    basic = eigenvalues(write, cantilever(bars("CBAR", orient, "BGG")), "basic.bdf")
    assert not np.allclose(old, basic, rtol=1e-6)
    deck = read_deck(write(cantilever(bars("CBAR", orient, 1))))
    assert deck.table("CBAR")["offt"].tolist() == ["GGG"] * 4


def test_cbar_old_flag_f2_with_g0_and_zeros_in_fields_7_8(write):
    """F = 2: field 6 is the grid G0, fields 7-8 "blank/0" [UM, CBAR; IFS1P 180: M(6), M(7)
    must be 0]. Zeros there (integer or real) read as blanks; the modes are the current G0
    form's."""
    new = eigenvalues(write, cantilever(bars("CBAR", [99])), "new.bdf")
    for orient in ([99], [99, 0, 0], [99, "0.", ".0"]):
        old = eigenvalues(write, cantilever(bars("CBAR", orient, 2)), "old.bdf")
        np.testing.assert_array_equal(old, new)


def test_baror_old_flag_gives_the_cbar_defaults(write):
    """BAROR field 9 F [UM, BAROR: F = 1 X1-X3, F = 2 G0, blank]: CBARs with blank fields 6-9
    take BAROR's orientation, as with the current BAROR."""
    blank = bars("CBAR", [])
    for orient, flag in (([0.0, 0.0, 1.0], 1), ([99, None, None], 2)):
        old = card("BAROR", None, 1, None, None, *orient, flag)
        new = card("BAROR", None, 1, None, None, *orient)
        a = eigenvalues(write, cantilever(blank, extra=old), "old.bdf")
        b = eigenvalues(write, cantilever(blank, extra=new), "new.bdf")
        np.testing.assert_array_equal(a, b)
    # A CBAR's own flag beside a blank field 6: the orientation is BAROR's.
    with_flag = bars("CBAR", [], 2)
    a = eigenvalues(write, cantilever(with_flag, extra=card("BAROR", None, 1, None, None, 99)))
    b = eigenvalues(write, cantilever(blank, extra=card("BAROR", None, 1, None, None, 99)),
                    "b.bdf")  # fmt: skip
    np.testing.assert_array_equal(a, b)


def test_cbeam_and_beamor_read_the_old_flag_as_cbar_does(write):
    """CBEAM field 9 is OFFT/BIT today; MSC's GEOM2 CBEAM record carries the same
    orientation flag F as CBAR's [DMAP], so an integer there is F, read as for CBAR."""
    orient = [0.0, 0.0, 1.0]
    new = eigenvalues(write, cantilever(bars("CBEAM", orient), beam=True), "new.bdf")
    old = eigenvalues(write, cantilever(bars("CBEAM", orient, 1), beam=True), "old.bdf")
    np.testing.assert_array_equal(old, new)
    g0 = eigenvalues(write, cantilever(bars("CBEAM", [99]), beam=True), "g0.bdf")
    old = eigenvalues(write, cantilever(bars("CBEAM", [99, "0"], 2), beam=True), "old2.bdf")
    np.testing.assert_array_equal(old, g0)
    beamor = card("BEAMOR", None, 1, None, None, 99, None, None, 2)
    old = eigenvalues(write, cantilever(bars("CBEAM", []), beam=True, extra=beamor), "bo.bdf")
    np.testing.assert_array_equal(old, g0)
    # a real in CBEAM field 9 is still BIT
    deck = read_deck(write(cantilever(bars("CBEAM", orient, "0.5"), beam=True)))
    assert deck.table("CBEAM")["bit"].tolist() == [0.5] * 4
    assert deck.table("CBEAM")["offt"].tolist() == [""] * 4


def test_obsolete_offset_code_e_reads_as_o(write):
    """[QRG, BAROR remark 5]: O replaces the obsolete character E. With end A offset in the
    offset system, GEG gives the modes of GOG (and not those of GGG)."""
    orient = [0.0, 0.0, 1.0]
    offsets = card("", None, None, 0.0, 20.0, 0.0)

    def offset_bars(code: str) -> str:
        return "".join(card("CBAR", e, 1, e, e + 1, *orient, code) + offsets
                       for e in range(1, 5))  # fmt: skip

    old = eigenvalues(write, cantilever(offset_bars("GEG")), "old.bdf")
    new = eigenvalues(write, cantilever(offset_bars("GOG")), "new.bdf")
    np.testing.assert_array_equal(old, new)
    assert not np.allclose(old, eigenvalues(write, cantilever(offset_bars("GGG")), "g.bdf"),
                           rtol=1e-6)  # fmt: skip
    deck = read_deck(write(cantilever(offset_bars("BEG"))))
    assert deck.table("CBAR")["offt"].tolist() == ["BOG"] * 4


def test_legacy_forms_read_the_same_in_every_format_and_both_lanes(write, monkeypatch):
    """Small, large and free field give the same rows, and the NumPy fast lane the same deck
    as the field-by-field reader (the fast lane leaves every non-blank OFFT field to it)."""
    from femcal.deck import reader as reader_module

    monkeypatch.setattr(reader_module, "BLOCK_LINES", 3)
    lines = [
        card("CBAR", 1, 1, 1, 2, ".0", ".0", "1.0", 1),
        card("CBAR", 2, 1, 2, 3, 99, 0, "0.", 2),
        card("CBAR", 3, 1, 3, 4, 0.0, 0.0, 1.0, "GEE"),
        card("CBAR", 4, 1, 4, 5, 0.0, 0.0, 1.0),
        "CBAR*   5               1               5               6\n"
        "*       0.              0.              1.              1\n",
        "CBAR,6,1,6,7,99,,,2\n",
        "cbar,7,1,7,8,0.,0.,1.,gog\n",
        card("BAROR", None, 1, None, None, 0.0, 1.0, 0.0, 1),
        card("CBEAM", 8, 1, 8, 9, 99, None, None, 2),
    ]
    path = write(HEAD + "".join(lines) + "ENDDATA\n")
    fast, slow = (read_deck(path, fast_lane=f) for f in (True, False))
    same_deck(fast, slow)
    t = fast.table("CBAR").columns
    assert t["offt"].tolist() == ["GGG", "GGG", "GOO", "", "GGG", "GGG", "GOG"]
    assert t["g0"].tolist()[1] == 99 and np.isnan(t["x2"][1]) and np.isnan(t["x3"][1])
    assert fast.table("BAROR")["offt"].tolist() == ["GGG"]
    assert fast.table("CBEAM")["offt"].tolist() == ["GGG"]


# ------------------------------------------------------------------------ refused, with reasons


def test_flag_that_contradicts_field_6_is_an_error(write):
    """[IFS1P 180] rejects F = 1 beside an integer field 6 and F = 2 beside a real one; the
    error names the file:line, card, element id, field and both readings."""
    text = cantilever(card("CBAR", 3, 1, 3, 4, 99, None, None, 1)
                      + card("CBAR", 4, 1, 4, 5, ".0", ".0", "1.0", 2)
                      + card("CBEAM", 5, 1, 1, 2, 99, None, None, 1))  # fmt: skip
    path = write(text)
    issues = errors_of(path)
    n = text.splitlines().index(card("CBAR", 3, 1, 3, 4, 99, None, None, 1).rstrip()) + 1
    assert issues == [
        f"{path}:{n}: CBAR field 9 (OFFT): found '1'; expected 2, the old orientation flag "
        "for a grid G0 (CBAR 3 gives G0 = 99 in field 6; F = 1 is for a vector X1-X3), or an "
        "OFFT code such as GGG",
        f"{path}:{n + 1}: CBAR field 9 (OFFT): found '2'; expected 1, the old orientation "
        "flag for a vector X1-X3 (CBAR 4 gives X1 = .0 in field 6; F = 2 is for a grid G0), "
        "or an OFFT code such as GGG",
        f"{path}:{n + 2}: CBEAM field 9 (OFFT/BIT): found '1'; expected 2, the old "
        "orientation flag for a grid G0 (CBEAM 5 gives G0 = 99 in field 6; F = 1 is for a "
        "vector X1-X3), or an OFFT code such as GGG",
    ]


@pytest.mark.parametrize("flag", ["0", "3", "-1", "12"])
def test_flag_other_than_1_or_2_is_an_error(write, flag):
    """[UM] documents F = 1 and 2 only; [IFS1P 179, 180] rejects F < 0 and F > 2. An
    explicit 0, which no manual documents, is refused too."""
    path = write(HEAD + card("CBAR", 3, 1, 3, 4, 0.0, 0.0, 1.0, flag))
    assert errors_of(path) == [
        f"{path}:6: CBAR field 9 (OFFT): found '{flag}'; expected an OFFT code (GGG, BGG, "
        "GGO, BGO, GOG, BOG, GOO or BOO) or the old orientation flag F: 1 for a vector "
        "X1-X3, 2 for a grid G0 in field 6"
    ]


def test_non_zero_fields_7_8_beside_f2_are_an_error(write):
    """F = 2 means G0 alone: fields 7-8 blank or 0 [UM, CBAR; IFS1P 180 rejects M(6), M(7)
    other than 0]. The card's other problems are reported with it."""
    path = write(HEAD + card("CBAR", 3, "x", 3, 4, 99, 0, "1.", 2))
    assert errors_of(path) == [
        f"{path}:6: CBAR field 3 (PID): found 'x'; expected an integer",
        f"{path}:6: CBAR field 8 (X3): found '1.'; expected blank or 0 (the old orientation "
        "flag F = 2 orients by the grid G0 alone)",
    ]


@pytest.mark.parametrize("code", ["OOO", "GXG", "GG", "GGGG", "EGG", "GBB"])
def test_offt_outside_the_quick_reference_guide_table_is_an_error(write, code):
    """[QRG]: only the eight codes of the table; "a value of OOO ... results in a fatal
    error". B is no end-offset code, and E only an obsolete end-offset code. Before, femcal
    took any word and read the unknown letters as basic."""
    for name in ("CBAR", "CBEAM"):
        path = write(HEAD + card(name, 3, 1, 3, 4, 0.0, 0.0, 1.0, code))
        label = "OFFT" if name == "CBAR" else "OFFT/BIT"
        assert errors_of(path) == [
            f"{path}:6: {name} field 9 ({label}): found '{code}'; "
            "expected an OFFT code: G or B for the orientation vector, then G or O for each "
            "end's offset (GGG, BGG, GGO, BGO, GOG, BOG, GOO or BOO)"
        ]


def test_cosmic_elements_current_nastran_dropped_are_named(write):
    """COSMIC NASTRAN's plate elements CQUAD2 and CTRIA2 [UM; NASTRAN-95 element table,
    ``mis/sdr2e.f``] are not in current NASTRAN. Kept as unknown cards they would leave their
    stiffness out of the modes; they are an error that names them."""
    path = write(HEAD + card("CQUAD2", 1, 1, 1, 2, 3, 4) + card("CTRIA2", 2, 1, 1, 2, 3))
    assert errors_of(path) == [
        f"{path}:{line}: {name}; expected a supported card ({name} is an element of older "
        "NASTRAN (COSMIC) femcal cannot model; it would change the SOL 103 answer)"
        for line, name in ((6, "CQUAD2"), (7, "CTRIA2"))
    ]
