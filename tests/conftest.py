"""Shared test helpers: writing small decks to temporary files, and the reference decks."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from femcal.parallel.executors import limit_openmp

# as the command line does, before anything loads CHOLMOD: the suite runs what users run
limit_openmp()

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


#: Every picture a test draws is read as a reader would: each axis with a label and a unit
#: (femcal.viz.figures.unlabelled_axes). What a test's pictures lack fails that test
#: (FEMCAL_AXES_SURVEY=FILE lists them in FILE instead, test by test).
_UNREADABLE: list[str] = []


def pytest_configure(config):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from femcal.viz.figures import unlabelled_axes

    original = Figure.savefig

    def savefig(self, *args, **kwargs):
        _UNREADABLE.extend(unlabelled_axes(self))
        return original(self, *args, **kwargs)

    Figure.savefig = savefig


@pytest.fixture(autouse=True)
def _pictures_are_readable(request):
    # what was drawn since the last test (its module's fixtures' pictures too) is this one's
    yield
    found, _UNREADABLE[:] = list(dict.fromkeys(_UNREADABLE)), []
    if os.environ.get("FEMCAL_AXES_SURVEY"):
        if found:
            with open(os.environ["FEMCAL_AXES_SURVEY"], "a") as fh:
                fh.write("".join(f"{request.node.nodeid}: {x}\n" for x in found))
        return
    assert not found, "pictures with unreadable axes: " + "; ".join(found)
