"""``femcal info DECK [--json FILE]``: what a deck holds."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..atomic import write_lines
from ..deck import read_deck
from ..model.build import build_model


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="summarise a NASTRAN deck: cards, grids, DOF, elements")
    p.add_argument("deck", type=Path, help="NASTRAN input file (.bdf, .dat, .nas)")
    p.add_argument("--json", type=Path, metavar="FILE", help="also write the summary as JSON")


def summarise(path: Path) -> dict:
    """The summary of a deck as a JSON-ready dict."""
    deck = read_deck(path)
    model = build_model(deck)
    return {
        "deck": str(path),
        "files": deck.files,
        "sol": deck.sol,
        "sol_text": deck.sol_text,
        "case_control": {
            "global": deck.case.global_,
            "subcases": {str(k): v for k, v in deck.case.subcases.items()},
        },
        "cards": dict(deck.card_count),
        "n_grids": model.n_grids,
        "n_spoints": model.n_spoints,
        "n_dof": model.n_dof,
        "n_elements": sum(len(b) for b in model.elements.values()),
        "elements": {k: len(b) for k, b in model.elements.items()},
        "coordinate_systems": sorted(int(c) for c in model.coords),
        "params": {k: list(v) for k, v in model.params.cards.items()},
        "unsupported": deck.unused_count,
    }


def run(args: argparse.Namespace) -> int:
    s = summarise(args.deck)
    print(
        f"deck      {s['deck']}"
        + (f" (+{len(s['files']) - 1} included)" if len(s["files"]) > 1 else "")
    )
    print(f"solution  SOL {s['sol_text'] or '-'}" + (f" ({s['sol']})" if s["sol"] else ""))
    print(f"grids     {s['n_grids']}   scalar points {s['n_spoints']}   DOF {s['n_dof']}")
    print(
        f"elements  {s['n_elements']}: " + ", ".join(f"{k} {v}" for k, v in s["elements"].items())
    )
    print("cards     " + ", ".join(f"{k} {v}" for k, v in s["cards"].items()))
    if s["unsupported"]:
        print(
            "not used by SOL 103: "
            + ", ".join(f"{k} \u00d7{v}" for k, v in s["unsupported"].items())
        )
    if args.json:
        write_lines(args.json, [json.dumps(s, indent=1)])
        print(f"wrote     {args.json}")
    return 0
