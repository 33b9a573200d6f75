"""PBAR values at the edges the Quick Reference Guide allows: I1, I2 and J of 0 (a blank
field is 0.0) are accepted; I1 * I2 > I12^2 is required only where I12 is given. A valid
deck refused is as wrong as an invalid one solved."""

from __future__ import annotations

import json

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.model.build import build_model
from femcal.solve.normal_modes import solve_normal_modes

from .conftest import REFDECKS

SWEPT = REFDECKS / "ekm_swept_plane"


def test_the_swept_wing_with_i2_blank_solves_to_msc_s_modes(tmp_path):
    """MSC's swept-wing stick (refdecks/ekm_swept_plane) with its PBAR's I2 left blank:
    GRDSET's permanent constraints hold the plane I2 would carry, so MSC's modes are those
    of the deck as published, and femcal's must be too."""
    text = (SWEPT / "sol103_swept_plane.bdf").read_text()
    blank = text.replace("*       6.66667-8       2.33071-7", "*                       2.33071-7")
    assert blank != text
    deck = tmp_path / "swept_i2_blank.bdf"
    deck.write_text(blank)
    modes, _ = solve_normal_modes(build_model(read_deck(deck)))
    reference = json.loads((SWEPT / "reference.json").read_text())["frequencies_hz"]
    f = modes.frequencies_hz[: len(reference)]
    assert np.all(np.abs(f[:3]) < 1e-3)  # three rigid-body modes on the SUPORT
    assert f[3:] == pytest.approx(reference[3:], rel=2e-6)


def _cantilever(pbar: str) -> str:
    """Ten CBARs along X, clamped at grid 1, a PBAR given as text."""
    grids = "\n".join(f"GRID,{i + 1},,{100.0 * i},0.,0." for i in range(11))
    bars = "\n".join(f"CBAR,{i + 1},1,{i + 1},{i + 2},0.,1.,0." for i in range(10))
    return (f"SOL 103\nCEND\nMETHOD = 1\nSPC = 1\nBEGIN BULK\nEIGRL,1,,,6\n{grids}\n{bars}\n"
            f"MAT1,1,2.1+5,,.3,7.85-9\nSPC1,1,123456,1\n{pbar}\nENDDATA\n")  # fmt: skip


def test_zero_inertias_give_no_stiffness_and_an_i12_needs_a_positive_determinant(write):
    """With I2 blank and the motions it bends in held, the modes are the full section's;
    with J blank the bar solves; negative values and an I12 with I1 * I2 <=
    I12^2 are refused."""
    full = solve_normal_modes(build_model(read_deck(write(_cantilever(
        "PBAR,1,1,100.,800.,1200.,1500.")))))[0].frequencies_hz
    # I2 blank, the motions it bends in held at every grid: only the I1 plane and the
    # axial and torsion modes remain, at the same frequencies as with the full section
    held = _cantilever("PBAR,1,1,100.,800.,,1500.").replace(
        "SPC1,1,123456,1", "SPC1,1,123456,1\nSPC1,1,35,2,THRU,11")
    both = _cantilever("PBAR,1,1,100.,800.,1200.,1500.").replace(
        "SPC1,1,123456,1", "SPC1,1,123456,1\nSPC1,1,35,2,THRU,11")
    f_blank = solve_normal_modes(build_model(read_deck(write(held, "b.bdf"))))[0]
    f_full = solve_normal_modes(build_model(read_deck(write(both, "f.bdf"))))[0]
    assert f_blank.frequencies_hz == pytest.approx(f_full.frequencies_hz, rel=1e-6)
    assert full[0] > 0
    # J blank is accepted: a CBAR's twist carries no mass, so its modes are the bending and
    # axial ones, as with J given
    no_j = solve_normal_modes(build_model(read_deck(write(_cantilever(
        "PBAR,1,1,100.,800.,1200.,"), "j.bdf"))))[0].frequencies_hz
    assert no_j == pytest.approx(full, rel=1e-6)
    for pbar, message in (("PBAR,1,1,100.,-800.,1200.,1500.", "PBAR 1 field I1 = -800: expected a real >= 0"),
                          ("PBAR,1,1,100.,800.,1200.,1500.\n,,,,,,,,\n,,,2000.",
                           "I1\\*I2 > I12\\^2")):  # fmt: skip
        with pytest.raises(Exception, match=message):
            solve_normal_modes(build_model(read_deck(write(_cantilever(pbar), "x.bdf"))))
