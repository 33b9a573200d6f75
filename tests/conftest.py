"""Shared test helpers: writing small decks to temporary files, and the reference decks."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFDECKS = ROOT.parent / "shared" / "refdecks"


def refdeck_cases() -> list[tuple[str, Path, dict]]:
    """(name, main file, reference.json) of every reference deck."""
    out = []
    for ref in sorted(REFDECKS.glob("*/reference.json")):
        data = json.loads(ref.read_text())
        out.append((data["name"], ref.parent / data["deck"]["main_file"], data))
    return out


@pytest.fixture
def write(tmp_path: Path):
    """write(text, name='deck.bdf') -> path of a file holding ``text``."""

    def _write(text: str, name: str = "deck.bdf") -> Path:
        p = tmp_path / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
        return p

    return _write


def solve_cantilever(coupled_mass: bool, n_modes: int = 1000):
    """The 10-CBAR cantilever reference deck solved for its lowest modes: (model, matrices,
    modes, reduction). With coupled mass every DOF (T2 and R3 of 10 grids) has a finite
    mode; with lumped mass the rotations are massless."""
    from femcal.assembly import Options, assemble
    from femcal.deck import read_deck
    from femcal.model import EigenRequest
    from femcal.model.build import build_model
    from femcal.solve.normal_modes import solve_normal_modes

    deck = read_deck(REFDECKS / "cofe_cantilever_cbar" / "noReduction.dat")
    model = build_model(deck)
    mats = assemble(model, Options(coupled_mass=coupled_mass))
    modes, red = solve_normal_modes(model, matrices=mats, request=EigenRequest(nd=n_modes))
    return model, mats, modes, red
