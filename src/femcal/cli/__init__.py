"""femcal command line: ``femcal SUBCOMMAND ...``; one module per subcommand."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from .. import __version__
from ..errors import FemcalError
from . import calibrate, frf, identify, info, model, solve, synth

_COMMANDS = {
    "info": info,
    "solve": solve,
    "frf": frf,
    "synth-test": synth,
    "identify": identify,
    "calibrate": calibrate,
    "model": model,
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="femcal",
        description="Finite-element normal modes and FRF-based calibration from NASTRAN decks.",
    )
    parser.add_argument("--version", action="version", version=f"femcal {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for _name, module in _COMMANDS.items():
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 ok, 1 failure, 2 bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(_COMMANDS[args.command].run(args) or 0)
    except FemcalError as e:
        print(f"femcal {args.command}: {e}", file=sys.stderr)
        return 2
    except (FileNotFoundError, IsADirectoryError, PermissionError) as e:
        print(f"femcal {args.command}: {e.strerror}: {e.filename}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
