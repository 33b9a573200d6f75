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
