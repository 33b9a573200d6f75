"""The calibrated deck is the engineer's deck, changed (issue 27): femcal.deck.edit changes a
field's text in place, in the card's own format (small, large, free field, tabs, continuation
lines), keeps every other byte, writes the INCLUDE files it changes beside the deck with every
INCLUDE still resolving, and names file:line, card, id and field when it cannot."""

from __future__ import annotations

import datetime
import difflib
import os
import re
from pathlib import Path

import numpy as np
import pytest

from femcal import __version__
from femcal.assembly import assemble
from femcal.calibrate.parameters import current_value, read_parameters, with_values
from femcal.deck import DeckEditError, FieldEdit, edit_deck, read_deck, write_edited_deck
from femcal.deck.edit import DIGITS, format_real
from femcal.deck.fields import parse_real
from femcal.io.calibration import calibrated_changes_name, write_calibrated_deck
from femcal.model.build import build_model, load_model

FRAME = Path(__file__).resolve().parents[1] / "models" / "truck_frame"

CASE = "SOL 103\nCEND\nMETHOD = 1\nBEGIN BULK\nEIGRL,1,,,4\n"
GRIDS = """GRID           1              0.      0.      0.
GRID           2            100.      0.      0.
GRID           3            200.      0.      0.
GRID           4              0.    100.      0.
GRID           5            100.    100.      0.
CQUAD4         1       1       1       2       5       4
CBAR           2       2       2       3      0.      0.      1.
CONM2        300       3            .002
"""


def _small(*fields: str) -> str:
    """A small-field line: the name, then each field right-aligned in 8 columns."""
    return fields[0].ljust(8) + "".join(f.rjust(8) for f in fields[1:])


def _large(*fields: str) -> str:
    """A large-field half line: the name (or ``*``), then each field right-aligned in 16."""
    return fields[0].ljust(8) + "".join(f.rjust(16) for f in fields[1:])


def _write(folder: Path, files: dict[str, str | bytes]) -> Path:
    """Write ``files`` (name -> text or bytes) under ``folder``; the first one's path."""
    for name, body in files.items():
        p = folder / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(body, str):
            p.write_bytes(body.encode("latin-1"))
        else:
            p.write_bytes(body)
    return folder / next(iter(files))


def _edit(path: Path, out: Path, *edits: FieldEdit, **kw) -> list[Path]:
    return write_edited_deck(edit_deck(path, list(edits)), out, **kw)


def _value(path: Path, card: str, ident: int, field: str) -> float:
    return current_value(build_model(read_deck(path)), card, ident, field)


def _changed(a: bytes, b: bytes) -> list[tuple[str, str]]:
    """The lines that differ between two texts of as many lines (each with its ending)."""
    la, lb = a.decode("latin-1").splitlines(True), b.decode("latin-1").splitlines(True)
    assert len(la) == len(lb)
    return [(x, y) for x, y in zip(la, lb, strict=True) if x != y]


# ------------------------------------------------------------------------------ numbers


@pytest.mark.parametrize(("value", "width", "text"), [
    (7.78816254694994, 8, "7.788163"), (7.78816254694994, 16, "7.788162547"),
    (204570.312, 8, "204570.3"), (20457031.0, 8, "2.0457+7"), (20457031.0, 16, "20457031."),
    (-0.000123456789, 8, "-1.235-4"), (0.5, 8, ".5"), (8.0, 8, "8."), (9.99999999, 8, "10."),
    (7.85e-9, 8, "7.85-9"), (123456789012.0, 8, "1.235+11"), (-2.5e-300, 8, "-2.5-300"),
])  # fmt: skip
def test_reals_take_the_most_digits_their_field_holds(value, width, text):
    got = format_real(value, width)
    assert got == text
    digits = len(re.sub(r"\D", "", re.split(r"(?<=\d)[+-]", got)[0]).lstrip("0"))
    assert digits <= DIGITS[width]
    assert parse_real(got) == pytest.approx(value, rel=0.5 * 10.0 ** (1 - digits))


def test_a_value_that_is_not_a_number_does_not_fit():
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match="not a number"):
            format_real(bad, 8)


# ------------------------------------------------------------------------------ the frame


def test_calibrated_hammer_frame_differs_only_in_its_calibrated_fields(tmp_path):
    deck = FRAME / "hammer_frame.bdf"
    model = load_model(deck)
    params = read_parameters(FRAME / "hammer_frame.params.toml", model)
    rng = np.random.default_rng(27)
    values = np.array([p.nominal * (1 + rng.uniform(-0.15, 0.15)) for p in params])
    out = tmp_path / "hammer_frame_calibrated.bdf"
    files = write_calibrated_deck(deck, params, values, out, config=tmp_path / "cal.toml")
    changes = tmp_path / calibrated_changes_name(out)
    assert files == [out, changes]
    a = deck.read_text(encoding="latin-1").splitlines(True)
    b = out.read_text(encoding="latin-1").splitlines(True)
    # the header, then the deck line for line
    today = datetime.date.today().isoformat()
    assert b[:3] == [f"$ femcal {__version__} calibrated deck, {today}\n",
                     f"$ config: {tmp_path / 'cal.toml'}\n",
                     f"$ changed: {len(params)} fields on {len(params)} cards (see "
                     "hammer_frame_calibrated.changes.bdf)\n"]  # fmt: skip
    ops = difflib.SequenceMatcher(None, a, b[3:], autojunk=False).get_opcodes()
    changed = {}
    for tag, i1, i2, j1, j2 in ops:
        assert tag in ("equal", "replace") and i2 - i1 == j2 - j1, (tag, a[i1:i2], b[j1:j2])
        if tag == "replace":
            changed.update({i + 1: (a[i], b[3 + j1 + i - i1]) for i in range(i1, i2)})
    src = read_deck(deck)
    where = {}
    for p in params:
        t = src.tables[p.card]
        row = int(np.flatnonzero(t.columns["mid" if p.card == "MAT1" else "pid"] == p.id)[0])
        where[int(t.line[row])] = p
    assert set(changed) == set(where)  # every calibrated card changed, no other line
    slot = {"E": 1, "T": 2, "A": 2}  # the field's place after the id (small field)
    written = []
    for line, p in where.items():
        old, new = changed[line]
        lo, hi = 8 + 8 * slot[p.field], 16 + 8 * slot[p.field]
        assert old[:lo] == new[:lo] and old[hi:] == new[hi:]  # every other field as it was
        text = new[lo:hi].strip()
        # one column kept blank: 7 characters, 6 significant digits
        assert len(text) <= 7 and parse_real(text) == pytest.approx(values[params.index(p)],
                                                                    rel=5e-6)  # fmt: skip
        written.append(parse_real(text))
    # the model of the written deck is the original with those values
    back = build_model(read_deck(out))
    expect = with_values(model, params, [written[list(where.values()).index(p)] for p in params])
    for p in params:
        assert current_value(back, p.card, p.id, p.field) == current_value(expect, p.card, p.id,
                                                                           p.field)  # fmt: skip
    for group in ("properties", "materials"):
        for card, table in getattr(expect, group).items():
            if isinstance(table, dict):
                for col, v in table.items():
                    np.testing.assert_array_equal(getattr(back, group)[card][col], v)
    k_back, k_expect = assemble(back), assemble(expect)
    for got, want in ((k_back.K, k_expect.K), (k_back.M, k_expect.M)):  # to rounding
        np.testing.assert_allclose(got.diagonal(), want.diagonal(), rtol=1e-13)
    assert not np.array_equal(k_back.K.diagonal(), assemble(model).K.diagonal())
    # the changed cards alone: the header, then per card its comment and its line
    lines = changes.read_text(encoding="latin-1").splitlines()
    assert lines[:3] == [x.rstrip("\n") for x in b[:3]]
    for line, p in where.items():
        new = changed[line][1].rstrip("\n")
        k = lines.index(new)
        assert re.fullmatch(rf"\$ {p.card} {p.id} {p.field}: [0-9.]+ -> [0-9.+-]+ \({p.name}\)",
                            lines[k - 1])  # fmt: skip
    assert len(lines) == 3 + 2 * len(params)
    changed_deck = read_deck(changes)
    assert sum(len(t) for t in changed_deck.tables.values()) == len(params)


def test_a_held_value_leaves_its_field_as_written(tmp_path):
    deck = FRAME / "hammer_frame.bdf"
    params = read_parameters(FRAME / "hammer_frame.params.toml", load_model(deck))[:3]
    values = [p.nominal for p in params]
    values[1] *= 1 + 1e-9  # below the field's 7 digits
    out = tmp_path / "held.bdf"
    write_calibrated_deck(deck, params, values, out)
    text = out.read_bytes()
    assert text.split(b"\n", 2)[1].startswith(b"$ changed: 0 fields on 0 cards")
    assert text.split(b"\n", 2)[2] == deck.read_bytes()


# ------------------------------------------------------------------------------ formats


def test_small_field_with_comments_and_a_continuation_line(tmp_path):
    conm2 = _small("CONM2", "300", "3", "", ".002", "", "", "", "") + "+C1"
    inertia = _small("+C1", "1.5", "0.", "2.5")
    deck = _write(tmp_path, {"d.bdf": CASE + GRIDS.replace(GRIDS.splitlines()[-1] + "\n", "")
                             + _small("MAT1", "1", "210000.", "", ".3", "7.85-9") + "\n"
                             + _small("PSHELL", "1", "1", "5.", "1", "", "1") + " $ plate\n"
                             + _small("PBAR", "2", "1", "120.", "900.", "1600.", "2000.") + "\n"
                             + conm2 + "\n$ the inertia, after a blank line\n\n"
                             + inertia + "  $ I11 I21 I22\nENDDATA\n"})  # fmt: skip
    out = tmp_path / "out" / "d.bdf"
    _edit(deck, out, FieldEdit("PSHELL", 1, "T", 7.78816254694994, "t"),
          FieldEdit("CONM2", 300, "I22", 2.0457e5), FieldEdit("CONM2", 300, "M", 0.0021))
    assert _changed(deck.read_bytes(), out.read_bytes()) == [
        (_small("PSHELL", "1", "1", "5.", "1", "", "1") + " $ plate\n",
         _small("PSHELL", "1", "1", "7.78816", "1", "", "1") + " $ plate\n"),
        (conm2 + "\n", conm2.replace("    .002", "   .0021") + "\n"),
        (inertia + "  $ I11 I21 I22\n",
         _small("+C1", "1.5", "0.", "204570.") + "  $ I11 I21 I22\n")]  # fmt: skip
    back = build_model(read_deck(out))
    assert current_value(back, "PSHELL", 1, "T") == 7.78816
    assert current_value(back, "CONM2", 300, "M") == 0.0021
    conm2 = back.elements["CONM2"].data
    assert conm2["i22"][0] == 204570.0 and conm2["i11"][0] == 1.5


def test_large_field_changes_a_field_on_the_second_half_line(tmp_path):
    mat1 = [_large("MAT1*", "1", "210000.", "", ".3") + "*", _large("*", "7.85-9")]
    pshell = _large("PSHELL*", "1", "1", "5.")
    deck = _write(tmp_path, {"d.bdf": CASE + GRIDS + "\n".join([*mat1, pshell]) + "\n"
                             + _small("PBAR", "2", "1", "120.", "900.", "1600.", "2000.")
                             + "\nENDDATA\n"})  # fmt: skip
    out = tmp_path / "out.bdf"
    _edit(deck, out, FieldEdit("MAT1", 1, "RHO", 7.85e-9 * 1.0123456789),
          FieldEdit("MAT1", 1, "E", 204570.312345678), FieldEdit("PSHELL", 1, "T", 5.25))
    assert _changed(deck.read_bytes(), out.read_bytes()) == [
        (mat1[0] + "\n", _large("MAT1*", "1", "204570.3123", "", ".3") + "*\n"),
        (mat1[1] + "\n", _large("*", "7.946913579-9") + "\n"),
        (pshell + "\n", _large("PSHELL*", "1", "1", "5.25") + "\n")]  # fmt: skip
    assert _value(out, "MAT1", 1, "RHO") == pytest.approx(7.85e-9 * 1.0123456789, rel=5e-10)
    assert _value(out, "MAT1", 1, "E") == 204570.3123
    assert _value(out, "PSHELL", 1, "T") == 5.25


def test_free_field_keeps_its_separators(tmp_path):
    deck = _write(tmp_path, {"d.bdf": CASE + GRIDS
                             + "MAT1, 1, 210000., , .3, 7.85-9\n"
                             "PSHELL,1,1,5.,1,,1\n"
                             "PBAR, 2, 1, 120. ,900.,1600.   $ J not given\n"
                             "PBUSH,4,K,40.,50.,60.,0.,0.,0.\n"
                             "PELAS,5,25.,,,6,30.\n"
                             "PBAR*,7,1,12.,90.\n*,160.,200.\n"
                             "ENDDATA\n"})  # fmt: skip
    out = tmp_path / "out.bdf"
    _edit(deck, out, FieldEdit("MAT1", 1, "E", 2.0457031e7), FieldEdit("PBAR", 2, "A", 123.4),
          FieldEdit("PBAR", 2, "J", 2100.0), FieldEdit("PBUSH", 4, "K3", 61.25),
          FieldEdit("PELAS", 6, "K", 29.5), FieldEdit("PBAR", 7, "J", 7.78816254694994))
    assert [y for _, y in _changed(deck.read_bytes(), out.read_bytes())] == [
        "MAT1, 1, 2.0457+7, , .3, 7.85-9\n",
        "PBAR, 2, 1, 123.4 ,900.,1600.,2100.   $ J not given\n",
        "PBUSH,4,K,40.,50.,61.25,0.,0.,0.\n",
        "PELAS,5,25.,,,6,29.5\n",
        "*,160.,7.788162547\n"]  # fmt: skip
    back = build_model(read_deck(out))
    assert current_value(back, "PBAR", 2, "J") == 2100.0
    assert current_value(back, "PBUSH", 4, "K3") == 61.25
    assert current_value(back, "PELAS", 5, "K") == 25.0
    assert current_value(back, "PELAS", 6, "K") == 29.5


def test_a_tabbed_line_keeps_its_tabs_and_columns(tmp_path):
    deck = _write(tmp_path, {"d.bdf": CASE + GRIDS
                             + "MAT1\t1\t210000.\t\t.3\t7.85-9\n"
                             "PSHELL\t1\t1\t5.\t1\t\t1\t$ tabbed\n"
                             "PBAR\t2\t1\t120.\t900.\t1600.\t2000.\n"
                             "ENDDATA\n"})  # fmt: skip
    out = tmp_path / "out.bdf"
    _edit(deck, out, FieldEdit("PSHELL", 1, "T", 5.5), FieldEdit("MAT1", 1, "E", 2.1e5 / 3),
          FieldEdit("PBAR", 2, "J", 1999.5))
    assert [y for _, y in _changed(deck.read_bytes(), out.read_bytes())] == [
        "MAT1\t1\t70000.\t\t.3\t7.85-9\n",
        "PSHELL\t1\t1\t5.5\t1\t\t1\t$ tabbed\n",
        "PBAR\t2\t1\t120.\t900.\t1600.\t1999.5\n"]  # fmt: skip
    back = build_model(read_deck(out))
    assert current_value(back, "PSHELL", 1, "T") == 5.5
    assert current_value(back, "PBAR", 2, "I2") == 1600.0
    _edit(deck, out, FieldEdit("MAT1", 1, "E", 2.1e5 / 9))  # 7 characters and its tab
    line = out.read_text().splitlines()[(CASE + GRIDS).count("\n")]
    assert line == "MAT1\t1\t23333.3\t\t.3\t7.85-9"
    mat1 = read_deck(out).tables["MAT1"].columns
    assert (mat1["e"][0], mat1["nu"][0], mat1["rho"][0]) == (23333.3, 0.3, 7.85e-9)


def test_line_endings_and_every_other_byte_are_kept(tmp_path):
    text = (CASE + GRIDS + "MAT1,1,210000.,,.3,7.85-9\nPSHELL         1       1      5.\n"
            "ENDDATA").replace("\n", "\r\n")  # CRLF, no ending on the last line
    deck = _write(tmp_path, {"d.bdf": text})
    out = tmp_path / "out.bdf"
    _edit(deck, out, FieldEdit("PSHELL", 1, "T", 4.5), header=["$ one", "$ two"])
    want = ("$ one\r\n$ two\r\n"
            + text.replace("PSHELL         1       1      5.", "PSHELL         1       1     4.5"))
    assert out.read_bytes() == want.encode()


# ------------------------------------------------------------------------------ INCLUDE


def test_included_cards_are_written_beside_the_deck_and_every_include_resolves(tmp_path):
    model_dir = tmp_path / "model"
    deck = _write(model_dir, {
        "main.bdf": (CASE + "INCLUDE 'sub/props.bdf'\ninclude \"mats.bdf\"  $ materials\n"
                     "INCLUDE 'grids.bdf'\nINCLUDE '../shared/bars.bdf'\nINCLUDE 'a.bdf'\n"
                     "ENDDATA\n"),
        "sub/props.bdf": "$ shell properties\nPSHELL         1       1      5.\nINCLUDE 'bar.bdf'\n",
        "sub/bar.bdf": "PBAR           2       1    120.    900.   1600.   2000.\n",
        "mats.bdf": "MAT1           1 210000.              .3  7.85-9\n",
        "grids.bdf": GRIDS,
        "a.bdf": "INCLUDE 'b.bdf'\n",
        "b.bdf": "PELAS          5     25.\nCELAS1       500       5       3       3\n",
        "../shared/bars.bdf": "MAT1           2  70000.              .3   2.7-9\n",
    })  # fmt: skip
    before = {p: p.read_bytes() for p in tmp_path.rglob("*.bdf")}
    out = tmp_path / "out" / "cal.bdf"
    files = _edit(deck, out, FieldEdit("PSHELL", 1, "T", 5.5), FieldEdit("MAT1", 1, "E", 2.2e5),
                  FieldEdit("MAT1", 2, "E", 7.1e4), FieldEdit("PELAS", 5, "K", 26.0))
    o = tmp_path / "out"
    assert sorted(files[1:]) == sorted([o / "sub/props.bdf", o / "mats.bdf", o / "bars.bdf",
                                        o / "a.bdf", o / "b.bdf"])  # fmt: skip
    assert {p: p.read_bytes() for p in before} == before  # the originals are untouched
    main = out.read_text().splitlines()
    # kept where they still resolve from out/, else relative to the original
    assert main[5:10] == ["INCLUDE 'sub/props.bdf'", 'include "mats.bdf"  $ materials',
                         "INCLUDE '../model/grids.bdf'", "INCLUDE 'bars.bdf'",
                         "INCLUDE 'a.bdf'"]  # fmt: skip
    assert (o / "sub/props.bdf").read_text().splitlines() == [
        "$ shell properties", "PSHELL         1       1     5.5",
        "INCLUDE '../../model/sub/bar.bdf'"]  # fmt: skip
    assert (o / "a.bdf").read_text() == "INCLUDE 'b.bdf'\n"  # written because b.bdf is
    back = build_model(read_deck(out))
    assert current_value(back, "PSHELL", 1, "T") == 5.5
    assert current_value(back, "MAT1", 1, "E") == 2.2e5
    assert current_value(back, "MAT1", 2, "E") == 7.1e4
    assert current_value(back, "PELAS", 5, "K") == 26.0
    assert current_value(back, "PBAR", 2, "A") == 120.0
    assert {os.path.realpath(f) for f in read_deck(out).files} >= {
        os.path.realpath(model_dir / "grids.bdf"), os.path.realpath(model_dir / "sub/bar.bdf")}


def test_writing_beside_the_deck_never_replaces_its_files(tmp_path):
    deck = _write(tmp_path, {"main.bdf": CASE + "INCLUDE 'props.bdf'\n" + GRIDS + "ENDDATA\n",
                             "props.bdf": "PSHELL         1       1      5.\n"
                                          "MAT1           1 210000.              .3  7.85-9\n"
                                          "PBAR           2       1    120.    900.\n"})
    before = (tmp_path / "props.bdf").read_bytes()
    out = tmp_path / "main_calibrated.bdf"
    files = _edit(deck, out, FieldEdit("PSHELL", 1, "T", 5.5), tag="calibrated")
    assert files == [out, tmp_path / "props_calibrated.bdf"]
    assert (tmp_path / "props.bdf").read_bytes() == before
    assert "INCLUDE 'props_calibrated.bdf'" in out.read_text()
    assert _value(out, "PSHELL", 1, "T") == 5.5
    with pytest.raises(DeckEditError, match=r"main.bdf: writing it would replace the deck's own"):
        _edit(deck, deck, FieldEdit("PSHELL", 1, "T", 5.5))
    # a file another deck wrote there is kept too
    files = _edit(deck, tmp_path / "again.bdf", FieldEdit("PSHELL", 1, "T", 5.75),
                  tag="calibrated", keep=files)
    assert files[1] == tmp_path / "props_calibrated_2.bdf"
    assert _value(out, "PSHELL", 1, "T") == 5.5
    assert _value(files[0], "PSHELL", 1, "T") == 5.75


def test_a_long_include_name_is_continued_over_lines(tmp_path):
    far = "a_folder_with_a_rather_long_name/and_another_one_below_it_that_is_long_too"
    deck = _write(tmp_path / "model", {"main.bdf": CASE + f"INCLUDE '../{far}/grids.bdf'\n"
                                       "PSHELL         1       1      5.\n"
                                       "MAT1           1 210000.              .3  7.85-9\n"
                                       "PBAR           2       1    120.    900.\n"
                                       "ENDDATA\n"})  # fmt: skip
    _write(tmp_path, {f"{far}/grids.bdf": GRIDS})
    out = tmp_path / "out" / "deeper" / "main.bdf"
    _edit(deck, out, FieldEdit("PSHELL", 1, "T", 6.0))
    lines = out.read_text().splitlines()
    k = next(i for i, x in enumerate(lines) if x.startswith("INCLUDE"))
    stmt = lines[k : lines.index("PSHELL         1       1      6.")]
    assert len(stmt) > 1 and all(len(x) <= 72 for x in stmt)
    assert "".join(x.strip() for x in stmt) == f"INCLUDE '../../{far}/grids.bdf'"
    assert _value(out, "PSHELL", 1, "T") == 6.0


# ------------------------------------------------------------------------------ errors


def test_what_cannot_be_changed_is_named_by_file_line_card_id_and_field(tmp_path):
    deck = _write(tmp_path, {"d.bdf": CASE + GRIDS
                             + "MAT1           1 210000.              .3  7.85-9\n"
                             "PSHELL         1       1      5.\n"
                             "PBAR           2       1    120.    900.   1600.   2000.\n"
                             "ENDDATA\n"})  # fmt: skip
    n = (CASE + GRIDS).count("\n")
    bad = [(FieldEdit("PSHELL", 1, "T", float("inf")),
            rf"d.bdf:{n + 2}: PSHELL 1 field T: inf is not a number"),
           (FieldEdit("PSHELL", 9, "T", 5.0), r"d.bdf: PSHELL 9 T: PSHELL 9 is not in the deck"),
           (FieldEdit("PSHELL", 1, "MID1", 5.0), r"PSHELL 1 MID1: PSHELL has no real field MID1"),
           (FieldEdit("PSOLID", 1, "T", 5.0), r"the deck has no PSOLID card"),
           (FieldEdit("PBAR", 2, "K1", 0.8),
            rf"d.bdf:{n + 3}: PBAR 2 field K1: the card has no line for it \(field 2 of logical "
            r"line 3\)")]  # fmt: skip
    for edit, message in bad:
        with pytest.raises(DeckEditError, match=message):
            edit_deck(deck, [edit])
    with pytest.raises(DeckEditError, match="changed twice"):
        edit_deck(deck, [FieldEdit("PSHELL", 1, "T", 5.5), FieldEdit("PSHELL", 1, "T", 6.0)])
    # the deck read before the file changed: the card is no longer where it says
    read = read_deck(deck)
    deck.write_text(deck.read_text().replace("PSHELL         1       1      5.",
                                             "PSHELL         1       1      6."))
    with pytest.raises(DeckEditError, match=rf"d.bdf:{n + 2}: PSHELL 1 field T: found '6.' "
                                            r"where the deck read 5.0"):  # fmt: skip
        edit_deck(deck, [FieldEdit("PSHELL", 1, "T", 5.5)], deck=read)
    deck.write_text(deck.read_text().replace("PSHELL ", "$SHELL "))
    with pytest.raises(DeckEditError, match=rf"d.bdf:{n + 2}: PSHELL 1 field T: no PSHELL card "
                                            "starts on this line"):  # fmt: skip
        edit_deck(deck, [FieldEdit("PSHELL", 1, "T", 5.5)], deck=read)
    # a free-field line that would pass column 80
    long = "PBAR,2,1," + ",".join(["1234.567800000000"] * 3) + ",1.00000000"
    assert len(long) == 73
    deck = _write(tmp_path, {"e.bdf": CASE + GRIDS + "MAT1,1,2.1+5,,.3\n" + long + "\n"
                             "PSHELL,1,1,5.\nENDDATA\n"})  # fmt: skip
    with pytest.raises(DeckEditError, match=r"e.bdf:\d+: PBAR 2 field NSM: 1.234568 does not "
                                            r"fit: the line's data would reach column 82"):
        edit_deck(deck, [FieldEdit("PBAR", 2, "NSM", 1.2345678)])
