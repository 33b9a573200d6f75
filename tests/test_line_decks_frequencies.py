"""Frequencies of the reference decks built of rods, bars, beams, bushes, springs and masses
(no rigid elements), against NASTRAN: within 0.1 %, near-zero modes near zero.

The element matrices are femcal's; the constraints and the eigensolution are a dense test
harness (tests/dense_modes.py) until the SOL 103 solver exists."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.model import build_model

from .conftest import refdeck_cases
from .dense_modes import dense_frequencies

LINE_DECKS = [
    "cofe_72_bar_truss", "cofe_cantilever_cbar", "cofe_svanberg_bar", "cofe_svanberg_beam",
    "cofe_ten_bar_truss", "cofe_three_element_types", "ekm_cbar_suport", "ekm_swept_plane",
    "pyn_beam_modes", "pyn_cbush_sol111", "pyn_satk_bar", "pyn_sdof_crod",
]  # fmt: skip
CASES = [c for c in refdeck_cases() if c[0] in LINE_DECKS]


def test_all_line_decks_present():
    assert len(CASES) == len(LINE_DECKS)


@pytest.mark.parametrize(("name", "main", "ref"), CASES, ids=[c[0] for c in CASES])
def test_frequencies_match_nastran(name, main, ref):
    deck = read_deck(main)
    f = dense_frequencies(deck, build_model(deck))
    modes = [m for m in ref["modes"] if m["valid"]]
    assert len(f) >= len(modes)
    fmax = max(m["cycles_hz"] for m in modes)
    for m, ours in zip(modes, f, strict=False):
        theirs = m["cycles_hz"]
        if theirs < 1e-3 * fmax:
            assert ours < 1e-3 * fmax, (m["mode"], ours, theirs)
        else:
            assert ours == pytest.approx(theirs, rel=1e-3), (m["mode"], ours, theirs)
    worst = max(
        abs(o / m["cycles_hz"] - 1)
        for m, o in zip(modes, f, strict=False)
        if m["cycles_hz"] >= 1e-3 * fmax
    )
    print(f"{name}: {len(modes)} modes, worst relative error {worst:.2e}")
    assert np.isfinite(worst)
