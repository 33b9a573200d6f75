"""Deck reader: field formats, continuations, comments, INCLUDE, sections, errors."""

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.errors import DeckError

HEAD = "SOL 103\nCEND\nBEGIN BULK\n"


def grid(deck, i=0):
    g = deck.table("GRID").columns
    return int(g["id"][i]), float(g["x1"][i]), float(g["x2"][i]), float(g["x3"][i])


def test_small_field(write):
    d = read_deck(write(HEAD + "GRID    1               1.5     2.      -3.\nENDDATA\n"))
    assert grid(d) == (1, 1.5, 2.0, -3.0)
    assert d.sol == 103


def test_large_field_with_star_continuation(write):
    text = (
        HEAD
        + "GRID*                  7               0             1.5             2.5\n"
        + "*                    3.5               0\n"
        + "ENDDATA\n"
    )
    d = read_deck(write(text))
    assert grid(d) == (7, 1.5, 2.5, 3.5)


def test_free_field_and_large_free_field(write):
    d = read_deck(write(HEAD + "GRID,3,,1.,2.,3.\nGRID*,4,,5.,6.\n*,7.\n"))
    assert grid(d, 0) == (3, 1.0, 2.0, 3.0)
    assert grid(d, 1) == (4, 5.0, 6.0, 7.0)


def test_tabs_lower_case_and_trailing_comment(write):
    d = read_deck(write(HEAD + "grid\t9\t\t1.e0\t2.\t3.  $ a comment, with a comma\n"))
    assert grid(d) == (9, 1.0, 2.0, 3.0)


def test_continuations_by_plus_star_and_blank(write):
    text = HEAD + (
        "CBAR    1       2       3       4       0.      0.      1.      GGG     +C1\n"
        "+C1                     0.      0.      1.      0.      0.      2.\n"
        "CBAR    2       2       3       4       0.      0.      1.\n"
        "                        0.      0.      3.\n"
        "GRID    3\nGRID    4               1.\nPBAR    2       1       1.\nMAT1    1       1.              .3\n"
    )
    d = read_deck(write(text))
    c = d.table("CBAR").columns
    assert c["w3a"].tolist() == [1.0, 3.0]
    assert c["w3b"].tolist() == [2.0, 0.0]
    assert c["offt"].tolist() == ["GGG", ""]


def test_half_large_line_then_small_continuation(write):
    # A large-field line carries 4 fields; a small continuation starts a new row of 8.
    text = HEAD + "CONM2*                 1               2\n+       1.      2.      3.\n"
    d = read_deck(write(text))
    c = d.table("CONM2").columns
    assert (c["eid"][0], c["g"][0], c["i11"][0], c["i21"][0], c["i22"][0]) == (1, 2, 1.0, 2.0, 3.0)


def test_comment_lines_and_blank_lines_are_skipped(write):
    d = read_deck(write(HEAD + "$ comment\n\nGRID    1\n$\n        \nGRID    2\n"))
    assert d.card_count["GRID"] == 2


def test_include_quoted_multiline_relative_and_nested(write):
    write("GRID    2\nINCLUDE 'deeper.inc'\n", "sub/part.inc")
    write("GRID    3\n", "sub/deeper.inc")
    main = write(HEAD + "GRID    1\nINCLUDE 'sub/\n part.inc'\nGRID    4\nENDDATA\n")
    d = read_deck(main)
    assert d.table("GRID")["id"].tolist() == [1, 2, 3, 4]
    assert len(d.files) == 3


def test_include_unquoted_and_in_case_control(write):
    write("SPC = 5\n", "case.inc")
    write("GRID    2\n", "bulk.inc")
    d = read_deck(write("SOL 103\nCEND\nINCLUDE case.inc\nBEGIN BULK\nINCLUDE bulk.inc\n"))
    assert d.case.value("SPC") == "5"
    assert d.table("GRID")["id"].tolist() == [2]


def test_include_cycle_is_an_error(write):
    write("INCLUDE 'b.inc'\n", "a.inc")
    write("INCLUDE 'a.inc'\n", "b.inc")
    with pytest.raises(DeckError, match="INCLUDE cycle"):
        read_deck(write(HEAD + "INCLUDE 'a.inc'\n"))


def test_missing_include_names_file_and_line(write):
    with pytest.raises(DeckError) as e:
        read_deck(write(HEAD + "GRID    1\nINCLUDE 'nothere.bdf'\n"))
    assert "deck.bdf:5" in str(e.value) and "nothere.bdf" in str(e.value)


def test_enddata_stops_reading(write):
    d = read_deck(write(HEAD + "GRID    1\nENDDATA\nGRID    2\nthis is not a card at all\n"))
    assert d.card_count == {"GRID": 1}


def test_bulk_only_file(write):
    d = read_deck(write("GRID    1\nGRID    2\n"))
    assert d.sol is None and d.card_count == {"GRID": 2}


@pytest.mark.parametrize(
    ("text", "sol"),
    [("SOL 103", 103), ("SOL SEMODES", 103), ("sol 111", 111), ("SOL SESTATIC", 101)],
)
def test_sol_names_and_numbers(write, text, sol):
    assert read_deck(write(f"{text}\nCEND\nBEGIN BULK\n")).sol == sol


def test_case_control_subcases_and_abbreviations(write):
    text = (
        "SOL 103\nCEND\nTITLE = My Frame, run 1\nSPC = 1\nSUBCASE 10\n  METH = 7\n  LABEL = a b\n"
        "SUBCASE 20\n  METHOD = 8\n  SPC = 2\nSET 3 = 1,2,\n  3,4\nBEGIN BULK\n"
    )
    d = read_deck(write(text))
    eff = dict(d.case.effective())
    assert eff[10]["METHOD"] == "7" and eff[10]["SPC"] == "1" and eff[10]["LABEL"] == "a b"
    assert eff[20]["SPC"] == "2"
    assert d.case.global_["TITLE"] == "My Frame, run 1"


def test_unused_cards_are_kept_and_counted(write):
    d = read_deck(
        write(
            HEAD + "FORCE   1       2       0       1.      1.\nFORCE   2\nCAERO1  5\nGRID    2\n"
        )
    )
    assert d.unused_count == {"FORCE": 2, "CAERO1": 1}
    assert d.card_count == {"FORCE": 2, "CAERO1": 1, "GRID": 1}


def test_unsupported_structural_card_is_an_error(write):
    with pytest.raises(DeckError, match=r"deck.bdf:4: CGAP.*SOL 103"):
        read_deck(write(HEAD + "CGAP    1       2       3       4\n"))


def test_error_names_file_line_card_field_and_text(write):
    with pytest.raises(DeckError) as e:
        read_deck(write(HEAD + "GRID    1\nCQUAD4  10      1       1       2       3       4.5\n"))
    issue = e.value.issues[0]
    assert (issue.line, issue.card, issue.field, issue.name, issue.found) == (
        5,
        "CQUAD4",
        7,
        "G4",
        "4.5",
    )
    assert "an integer" in issue.expected
    assert "deck.bdf:5: CQUAD4 field 7 (G4): found '4.5'; expected an integer" in str(e.value)


def test_error_on_continuation_line_points_at_that_line(write):
    text = HEAD + "CBAR    1       2       3       4       0.      0.      1.\n+       1.x\n"
    with pytest.raises(DeckError) as e:
        read_deck(write(text))
    issue = e.value.issues[0]
    assert issue.line == 5 and issue.name == "PA" and issue.found == "1.x"


def test_all_errors_are_collected(write):
    text = (
        HEAD
        + "GRID    x\nGRID    1       0       a\nCROD    1\nCONM2   1       1               1\n"
    )
    with pytest.raises(DeckError) as e:
        read_deck(write(text))
    found = [(i.line, i.name) for i in e.value.issues]
    assert found == [(4, "ID"), (5, "X1"), (6, "G1"), (6, "G2"), (7, "M")]


def test_error_limit(write):
    bad = "GRID    x\n" * 150
    with pytest.raises(DeckError) as e:
        read_deck(write(HEAD + bad), max_errors=10)
    assert len(e.value.issues) == 10 and e.value.truncated == 140
    assert "and 140 more" in str(e.value)


def test_required_field_blank(write):
    with pytest.raises(DeckError, match=r"G2.*required"):
        read_deck(write(HEAD + "CROD    1       2       3\n"))


def test_field_that_must_be_blank(write):
    with pytest.raises(DeckError, match="blank field"):
        read_deck(
            write(HEAD + "CONM2   1       2       0       1.      0.      0.      0.      9\n")
        )


def test_too_many_fields(write):
    with pytest.raises(DeckError, match="at most 4 data fields"):
        read_deck(write(HEAD + "CROD    1       2       3       4       5\n"))


def test_continuation_without_card(write):
    with pytest.raises(DeckError, match="continuation line with no card"):
        read_deck(write(HEAD + "+       1       2\n"))


def test_text_past_column_80_is_an_error(write):
    line = "GRID    1" + " " * 71 + "extra"
    with pytest.raises(DeckError, match="column 80"):
        read_deck(write(HEAD + line + "\n"))


def test_free_field_too_many_fields(write):
    with pytest.raises(DeckError, match="free-field"):
        read_deck(write(HEAD + "SPC1,1,123,1,2,3,4,5,6,+,7,8\n"))


def test_begin_super_is_refused(write):
    with pytest.raises(DeckError, match="superelements"):
        read_deck(write("SOL 103\nCEND\nBEGIN SUPER=1\nGRID 1\n"))


def test_nonexistent_main_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_deck(tmp_path / "none.bdf")


def test_table_columns_are_typed(write):
    d = read_deck(write(HEAD + "GRID    1\nGRID    2       0       1.\n"))
    g = d.table("GRID").columns
    assert g["id"].dtype == np.int64 and g["x1"].dtype == np.float64
