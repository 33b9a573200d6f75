"""NASTRAN punch files of eigenvalues and eigenvectors: NASTRAN's 80-column layout, read back
to the solved eigenvectors (in each grid's CD frame), and ``femcal solve --pch``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from femcal.cli import main
from femcal.deck import read_deck
from femcal.io.punch import PunchError, punch_lines, read_punch, write_punch
from femcal.model.build import build_model, load_model
from femcal.solve.normal_modes import solve_normal_modes

from .conftest import ROOT

LADDER = ROOT / "models" / "examples" / "ladder_frame.bdf"

#: A cantilever of three CBARs along basic x with a tip mass; GRID 3's displacement frame
#: (CD 7) has its z axis along (1, 1, 1) and its x axis in the plane of z and basic x. (A
#: CBAR's orientation vector is in its GA's CD frame: the bars start at basic grids, so that
#: the model is the same with and without CD 7.)
CD_DECK = """SOL 103
CEND
TITLE = Rotated CD frame
METHOD = 1
SPC = 1
BEGIN BULK
EIGRL,1,,,6
CORD2R,7,,0.,0.,0.,1.,1.,1.
,1.,0.,0.
GRID,1,,0.,0.,0.
GRID,2,,100.,0.,0.
GRID,3,,200.,0.,0.,{cd}
GRID,4,,300.,0.,0.
CBAR,1,1,1,2,0.,0.,1.
CBAR,2,1,2,3,0.,0.,1.
CBAR,3,1,4,3,0.,0.,1.
PBAR,1,1,100.,1000.,3000.,2000.
MAT1,1,70000.,,0.3,2.7-9
CONM2,10,4,,0.001,,,,,+
+,1.,,1.,,,1.
SPC1,1,123456,1
ENDDATA
"""


@pytest.fixture(scope="module")
def ladder():
    model = load_model(LADDER)
    modes, _ = solve_normal_modes(model)
    return model, modes


def grid_values(modes) -> np.ndarray:
    """(k, n, 6) the solved components of every node (CD frames), as a punch file holds
    them (a scalar point's in column 0)."""
    rows = modes.dof_start[:, None] + np.arange(6)
    rows = np.where(modes.is_grid[:, None], rows, modes.dof_start[:, None])
    vals = modes.shapes[np.minimum(rows, len(modes.shapes) - 1)].transpose(2, 0, 1)
    vals[:, ~modes.is_grid, 1:] = 0.0
    return vals


def test_ladder_frame_punch_has_nastrans_layout_and_reads_back(tmp_path, ladder):
    model, modes = ladder
    path = write_punch(tmp_path / "ladder.pch", modes, title="Ladder frame example",
                       subtitle="femcal", subcase=1)  # fmt: skip
    lines = path.read_text().splitlines()
    k, n = len(modes.eigenvalues), model.n_nodes
    assert len(lines) == k * (7 + 2 * n)
    assert all(len(line) == 80 for line in lines)
    assert [int(line[72:]) for line in lines] == list(range(1, len(lines) + 1))
    assert lines[0].startswith("$TITLE   = Ladder frame example")
    assert lines[1].startswith("$SUBTITLE= femcal")
    assert [line[:72].rstrip() for line in lines[2:6]] == [
        "$LABEL   =", "$EIGENVECTOR", "$REAL OUTPUT", "$SUBCASE ID =           1"]
    # the columns readers take the values from (SU2's readPunchShapes.m: eigenvalue 16-28,
    # mode 38-42, point type 16-20, values 24-72)
    eig = lines[6]
    assert eig.startswith("$EIGENVALUE = ") and eig[28:37] == "  MODE = "
    assert float(eig[15:28]) == pytest.approx(modes.eigenvalues[0], rel=1e-7)
    assert int(eig[37:42]) == 1
    first, cont = lines[7], lines[8]
    assert int(first[:10]) == model.node_ids[0] and first[15:20] == "  G  "
    assert cont.startswith("-CONT-" + " " * 12)
    u = grid_values(modes)
    assert [float(x) for x in first[23:72].split()] == pytest.approx(u[0, 0, :3], rel=1e-6)
    assert [float(x) for x in cont[23:72].split()] == pytest.approx(u[0, 0, 3:], rel=1e-6,
                                                                    abs=1e-12)  # fmt: skip
    back = read_punch(path)
    assert back.title == "Ladder frame example" and back.subcase == 1
    np.testing.assert_array_equal(back.modes, np.arange(1, k + 1))
    np.testing.assert_array_equal(back.point_ids, model.node_ids)
    assert set(back.point_types.tolist()) == {"G"}
    # print precision: E14.7 eigenvalues, E13.6 components
    np.testing.assert_allclose(back.eigenvalues, modes.eigenvalues, rtol=1e-7)
    scale = np.abs(u).max(axis=(1, 2))[:, None, None]
    assert (np.abs(back.values - u) <= 1e-6 * scale).all()


def test_punch_values_are_in_the_grids_cd_frames(write, tmp_path):
    basic = build_model(read_deck(write(CD_DECK.format(cd=""), "basic.bdf")))
    rotated = build_model(read_deck(write(CD_DECK.format(cd=7), "rotated.bdf")))
    frame = rotated.cd_frames[rotated.node_index(3)[0]]
    assert np.allclose(frame[:, 2], np.ones(3) / 3**0.5)  # z along (1, 1, 1)
    m0, _ = solve_normal_modes(basic)
    m1, _ = solve_normal_modes(rotated)
    np.testing.assert_allclose(m1.eigenvalues, m0.eigenvalues, rtol=1e-9)
    p0 = read_punch(write_punch(tmp_path / "basic.pch", m0))
    p1 = read_punch(write_punch(tmp_path / "rotated.pch", m1))
    g3 = int(np.flatnonzero(p1.point_ids == 3)[0])
    moved = 0
    for k in range(len(m0.eigenvalues)):
        u0, u1 = p0.values[k], p1.values[k]
        others = np.arange(4) != g3  # basic in both decks: they fix each mode's sign
        ref = np.unravel_index(np.argmax(np.abs(u0[others])), u0[others].shape)
        sign = np.sign(u0[others][ref] * u1[others][ref])
        tol = 2e-6 * np.abs(u0).max()
        assert np.abs(sign * u1[others] - u0[others]).max() <= tol
        # GRID 3 is punched in CD 7: T = R^T t_basic, R = R^T r_basic
        expected = np.r_[frame.T @ u0[g3, :3], frame.T @ u0[g3, 3:]]
        assert np.abs(sign * u1[g3] - expected).max() <= tol
        if np.abs(u0[g3, :3]).max() > 0.1 * np.abs(u0).max():  # a mode that moves GRID 3
            assert not np.allclose(u1[g3, :3], u0[g3, :3], atol=tol)
            moved += 1
        # and the solved shapes are kept in the CD frame as they are
        start = m1.dof_start[rotated.node_index(3)[0]]
        assert np.abs(u1[g3] - m1.shapes[start:start + 6, k]).max() <= tol
    assert moved >= 2  # bending modes, where the frames' difference shows


def test_scalar_points_are_punched_as_type_s(write, tmp_path):
    deck = ("SOL 103\nCEND\nMETHOD = 1\nBEGIN BULK\nEIGRL,1,,,2\nSPOINT,7,8\n"
            "CELAS2,1,100.,7,0,8,0\nCELAS2,2,50.,8,0\nCMASS2,3,1.,7,0\nCMASS2,4,2.,8,0\n"
            "ENDDATA\n")  # fmt: skip
    model = build_model(read_deck(write(deck)))
    modes, _ = solve_normal_modes(model)
    lines = list(punch_lines(modes))
    assert lines[7][:18] == "         7       S" and lines[8].startswith("-CONT-")
    back = read_punch(write_punch(tmp_path / "s.pch", modes))
    assert back.point_types.tolist() == ["S", "S"]
    np.testing.assert_allclose(back.values[:, :, 0], modes.shapes.T, rtol=1e-6)
    assert (back.values[:, :, 1:] == 0).all()


def test_a_damaged_punch_file_is_an_error_naming_the_line(tmp_path, ladder):
    _, modes = ladder
    lines = list(punch_lines(modes))
    bad = tmp_path / "bad.pch"
    bad.write_text("\n".join(lines[:7] + lines[8:]) + "\n")  # a point line lost
    with pytest.raises(PunchError, match=r"bad\.pch:8: a -CONT- line without its point"):
        read_punch(bad)
    bad.write_text("\n".join([*lines[:7], lines[7][:30] + "x.yE+00" + lines[7][37:]]) + "\n")
    with pytest.raises(PunchError, match=r"bad\.pch:8: T1 .* is not a number"):
        read_punch(bad)
    bad.write_text("$TITLE = nothing\n")
    with pytest.raises(PunchError, match="no \\$EIGENVECTOR block"):
        read_punch(bad)


def test_cli_solve_writes_the_punch_file_with_the_decks_title(tmp_path, capsys):
    path = tmp_path / "out" / "ladder.pch"
    assert main(["solve", str(LADDER), "--pch", str(path)]) == 0
    assert "ladder.pch (12 eigenvectors, CD frames)" in capsys.readouterr().err
    back = read_punch(path)
    assert back.title == "Ladder frame example" and len(back.eigenvalues) == 12
    model = load_model(LADDER)
    modes, _ = solve_normal_modes(model)
    np.testing.assert_allclose(back.eigenvalues, modes.eigenvalues, rtol=1e-7)
    assert not list(path.parent.glob(".*"))  # no temporary left


@pytest.mark.parametrize(("name", "expected"), [
    ("modes.txt", r"--pch .*modes\.txt: suffix '\.txt'; expected \.pch or \.punch"),
    ("folder", r"--pch .*folder: is a directory; expected a file name"),
    ("afile/modes.pch", r"--pch .*afile/modes\.pch: .*afile is a file, not a directory"),
])  # fmt: skip
def test_cli_refuses_bad_punch_paths_before_solving(tmp_path, capsys, name, expected):
    import re

    (tmp_path / "folder").mkdir()
    (tmp_path / "afile").write_text("x")
    argv = ["solve", str(tmp_path / "not-read.bdf"), "--pch", str(tmp_path / name)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(expected, err[0]), err
    assert not Path(tmp_path / "modes.txt").exists()
