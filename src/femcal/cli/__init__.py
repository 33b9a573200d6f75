"""femcal command line: ``femcal SUBCOMMAND ...``; one module per subcommand."""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from types import ModuleType

from .. import __version__
from ..errors import FemcalError
from ..parallel.executors import limit_openmp
from .examples import annotate

#: The subcommands and their modules (each with ``add_parser(subparsers)`` and ``run(args)``).
#: A command imports its own module only: ``femcal solve`` does not load what identification
#: or the rig need (SciPy's signal and statistics packages, about a second).
_COMMANDS = {
    "info": "info",
    "solve": "solve",
    "frf": "frf",
    "synth-test": "synth",
    "synth-rig-test": "synth_rig",
    "identify": "identify",
    "calibrate": "calibrate",
    "correlate": "correlate",
    "init": "init",
    "model": "model",
    "timedata": "timedata",
    "study": "study",
    "rig": "rig",
}


def _module(command: str) -> ModuleType:
    return importlib.import_module(f".{_COMMANDS[command]}", __name__)


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser; with ``only`` (a command's name) that command alone."""
    parser = argparse.ArgumentParser(
        prog="femcal",
        description="Finite-element normal modes and FRF-based calibration from NASTRAN decks.",
    )
    parser.add_argument("--version", action="version", version=f"femcal {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in [only] if only in _COMMANDS else _COMMANDS:
        _module(name).add_parser(sub)
    annotate(parser)
    return parser


#: Exit statuses: 0 done, 1 a resource failed (memory, disk), 2 bad input, 70 a bug in femcal
#: (sysexits' EX_SOFTWARE), 130 interrupted (128 + SIGINT, the shell's convention).
EXIT_OK, EXIT_RESOURCE, EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 70, 130

#: Set (to anything but 0) to see the traceback of an internal error.
TRACEBACK_ENV = "FEMCAL_TRACEBACK"


class _Terminated(BaseException):
    """SIGTERM, raised in the main thread so that cleanups run as for Ctrl-C."""


@contextmanager
def _one_line_warnings(command: str) -> Iterator[None]:
    """Every warning (femcal's and NumPy's) printed as one line ``femcal CMD: warning: ...``,
    each text once, instead of Python's two lines with the source line that raised it."""
    seen: set[str] = set()

    def show(msg, category, filename, lineno, file=None, line=None) -> None:
        text = str(msg)
        if text not in seen:
            seen.add(text)
            print(f"femcal {command}: warning: {text}", file=sys.stderr, flush=True)

    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = show
        yield


def _on_sigterm(signum: int, frame: object) -> None:
    raise _Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (see ``EXIT_*``). Nothing but femcal's own one-line
    messages reaches the user: an unexpected exception is reported as an internal error (its
    traceback with ``FEMCAL_TRACEBACK=1``), Ctrl-C and SIGTERM as an interruption."""
    words = list(sys.argv[1:] if argv is None else argv)
    # the command named first (not an option's value: no top-level option takes one)
    first = next((w for w in words if not w.startswith("-")), None)
    args = build_parser(first if first in _COMMANDS else None).parse_args(words)
    # the whole command, its action too (``femcal rig iterate``, ``femcal timedata frf``)
    name = " ".join(["femcal", args.command, *([args.action] if getattr(args, "action", None)
                                               else [])])  # fmt: skip
    previous = signal.getsignal(signal.SIGTERM)
    try:
        signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread: leave SIGTERM alone
        previous = None
    try:
        with _one_line_warnings(name.removeprefix("femcal ")):
            return int(_module(args.command).run(args) or 0)
    except FemcalError as e:
        print(f"{name}: {e}", file=sys.stderr)
        return EXIT_INPUT
    except (FileNotFoundError, IsADirectoryError, NotADirectoryError, FileExistsError,
            PermissionError) as e:  # fmt: skip
        print(f"{name}: {e.strerror}: {e.filename}", file=sys.stderr)
        return EXIT_INPUT
    except (KeyboardInterrupt, _Terminated):
        print(f"{name}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except MemoryError:
        print(f"{name}: out of memory", file=sys.stderr)
        return EXIT_RESOURCE
    except OSError as e:  # disk full, I/O error, ...
        where = f": {e.filename}" if e.filename else ""
        print(f"{name}: {e.strerror or e}{where}", file=sys.stderr)
        return EXIT_RESOURCE
    except Exception as e:
        if os.environ.get(TRACEBACK_ENV, "0") not in ("", "0"):
            raise
        print(f"{name}: internal error ({type(e).__name__}: {e}); this is a bug in femcal: "
              f"please report it with the input (set {TRACEBACK_ENV}=1 for the traceback)",
              file=sys.stderr)  # fmt: skip
        return EXIT_INTERNAL
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def entry() -> None:
    """The ``femcal`` command: :func:`main`, then exit with its status. After an interruption
    the process ends at once (``os._exit``): a Ctrl-C that lands inside the standard
    library's process pools can leave one of their locks held, and the interpreter's own
    exit (which joins the pools' threads) would then wait forever. femcal's files are whole
    or absent by then, and the workers end with their parent. The OpenMP runtime is capped
    at one thread first, before a command loads CHOLMOD
    (:func:`femcal.parallel.executors.limit_openmp`)."""
    limit_openmp()
    status = main()
    if status == EXIT_INTERRUPTED:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)
    sys.exit(status)


if __name__ == "__main__":  # pragma: no cover
    entry()
