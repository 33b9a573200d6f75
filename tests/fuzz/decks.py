"""Seeded mutations of real decks, run through reading, building and the SOL 103 solution.

Each case takes one seed deck (the reference decks of ``shared/refdecks`` that solve in well
under a second, and the bundled ladder frame with its INCLUDE), applies one to three random
mutations to its text, and runs :func:`femcal.deck.reader.read_deck`,
:func:`femcal.model.build.build_model` and :func:`femcal.solve.normal_modes.solve_normal_modes`
under an alarm. The outcome is

* ``ok``: modes came out, and the deck written back by femcal (:mod:`femcal.deck.writer`)
  and read again gives the same modes (the oracle: a deck that parses must mean one thing);
* ``error``: one of femcal's own errors (:class:`femcal.errors.FemcalError`) or a file the
  command line reports in one line (missing, a directory, no permission);
* ``crash``: any other exception (a traceback for the user: a bug);
* ``hang``: the case ran past its time limit;
* ``wrong``: modes came out, but the deck written back gives other ones.

Run by ``tests/test_fuzz_decks.py`` (a quick seeded run) and ``benchmarks/fuzz.py`` (the long
one). A case is reproduced from its seed alone: :func:`mutated_deck` rebuilds the text.
"""

from __future__ import annotations

import json
import random
import signal
import tempfile
import time
import traceback
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from femcal.deck.cards import CARDS
from femcal.deck.reader import read_deck
from femcal.deck.writer import write_deck
from femcal.errors import FemcalError
from femcal.model.build import build_model
from femcal.solve.normal_modes import solve_normal_modes

ROOT = Path(__file__).resolve().parents[2]
REFDECKS = ROOT.parent / "shared" / "refdecks"
#: Reference decks too big for thousands of solves (seconds each) or that femcal refuses.
SKIP = ("pyn_bwb", "yeti_outboard_extseout", "pyn_cbush_sol111")
#: Exceptions the command line turns into one clean line (femcal.cli.main).
CLEAN = (FemcalError, FileNotFoundError, IsADirectoryError, NotADirectoryError,
         PermissionError)  # fmt: skip
OUTCOMES = ("ok", "error", "crash", "hang", "wrong")


class _Timeout(BaseException):
    """The alarm of a case that ran past its limit."""


@dataclass(frozen=True)
class SeedDeck:
    """A deck to mutate: its name, main file name and every file's text (INCLUDEs too)."""

    name: str
    main: str
    files: dict[str, str]


@dataclass(frozen=True)
class Finding:
    """One case: its seed (which rebuilds it), the seed deck, the mutations, the outcome and,
    for anything but ``ok``, the exception's type and text (the last traceback line for a
    crash)."""

    seed: int
    deck: str
    mutations: tuple[str, ...]
    outcome: str
    detail: str = ""
    seconds: float = 0.0


def seed_decks() -> list[SeedDeck]:
    """The decks the cases mutate (reference decks with their INCLUDEs, the ladder frame)."""
    out = []
    for ref in sorted(REFDECKS.glob("*/reference.json")):
        data = json.loads(ref.read_text())
        if data["name"] in SKIP:
            continue
        main = ref.parent / data["deck"]["main_file"]
        files = {p.name: p.read_text(encoding="latin-1") for p in ref.parent.iterdir()
                 if p.is_file() and p.suffix.lower() in (".bdf", ".dat", ".nas", ".inc",
                                                          ".blk")}  # fmt: skip
        out.append(SeedDeck(data["name"], main.name, files))
    ladder = ROOT / "models" / "examples"
    out.append(SeedDeck("ladder_frame", "ladder_frame.bdf",
                        {p.name: p.read_text() for p in ladder.iterdir()}))  # fmt: skip
    return out


# ---------------------------------------------------------------- mutations

#: Field texts a hostile user types.
_NASTY = ("", "0", "-1", "-5", "1", "0.", "-0.", "-1.", "1.+400", "1.-400", "1.e30", "-1.e30",
          "nan", "NAN", "inf", "9223372036854775808", "99999999", "100000000", "1.5", "abc",
          "1..2", "+", "*", "'", '"', "$", ",", "\t", "é", "1D3", "7", "123456", "1234567",
          "0.5", "0.50001", "-0.99", "-1.5", "1e-300", "3.4+38", "THRU", "ALL", "MASS", "MAX")
#: Field texts of planted cards: the nasty ones and plausible ones.
_PLANTED = (*_NASTY, "1", "2", "3", "10", "1.", "100.")
#: Case control lines to plant.
_CASE = ("SPC = 77", "MPC = 77", "SCP = 1", "METHOD =", "METHOD = 999", "SPC =", "SUBCASE 2",
         "SUBCASE", "AUTOSPC = NO", "DISP = ALL", "SET 1 = 1 THRU", "ECHO", "K2GG = KAA",
         "TITLE = " + "x" * 300)  # fmt: skip
_SOLS = ("SOL 101", "SOL 10", "SOL 103", "SOL SEMODES", "SOL 0", "SOL -3", "SOL", "SOL 1e3")


def _bulk_range(lines: list[str]) -> tuple[int, int]:
    start = next((i + 1 for i, ln in enumerate(lines) if ln.upper().startswith("BEGIN")), 0)
    end = next((i for i, ln in enumerate(lines) if ln.upper().startswith("ENDDATA")),
               len(lines))  # fmt: skip
    return start, max(end, start)


def _split_fields(line: str) -> tuple[list[str], str]:
    if "," in line.split("$")[0]:
        return line.split(","), "free"
    width = 16 if line[:8].rstrip().endswith("*") else 8
    head, rest = line[:8], line[8:]
    return [head] + [rest[k:k + width] for k in range(0, len(rest), width)], f"fixed{width}"


def _join_fields(fields: list[str], kind: str) -> str:
    if kind == "free":
        return ",".join(fields)
    width = int(kind[5:])
    return fields[0][:8].ljust(8) + "".join(f[:width].rjust(width) for f in fields[1:])


def _mutate_field(rng: random.Random, lines: list[str]) -> str:
    a, b = _bulk_range(lines)
    if a >= b:
        return "no bulk line"
    i = rng.randrange(a, b)
    fields, kind = _split_fields(lines[i])
    if len(fields) < 2:
        return "no field"
    k = rng.randrange(1, len(fields))
    new = rng.choice(_NASTY)
    fields[k] = new
    lines[i] = _join_fields(fields, kind)
    return f"line {i + 1} field {k + 1} -> {new!r}"


def _delete_line(rng: random.Random, lines: list[str]) -> str:
    i = rng.randrange(len(lines))
    del lines[i]
    return f"delete line {i + 1}"


def _duplicate_line(rng: random.Random, lines: list[str]) -> str:
    i = rng.randrange(len(lines))
    lines.insert(i, lines[i])
    return f"duplicate line {i + 1}"


def _swap_lines(rng: random.Random, lines: list[str]) -> str:
    i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
    lines[i], lines[j] = lines[j], lines[i]
    return f"swap lines {i + 1} and {j + 1}"


def _truncate(rng: random.Random, lines: list[str]) -> str:
    i = rng.randrange(len(lines))
    cut = rng.randrange(len(lines[i]) + 1)
    lines[i] = lines[i][:cut]
    del lines[i + 1:]
    return f"cut at line {i + 1} column {cut}"


def _plant_card(rng: random.Random, lines: list[str]) -> str:
    a, b = _bulk_range(lines)
    name = rng.choice(sorted(CARDS))
    values = [rng.choice(_PLANTED) for _ in range(rng.randrange(1, 12))]
    lines.insert(rng.randint(a, b), ",".join([name, *values]))
    return f"plant {name} {values}"


def _case_control(rng: random.Random, lines: list[str]) -> str:
    where = next((i for i, ln in enumerate(lines) if ln.upper().startswith("CEND")), None)
    if where is None:
        return "no case control"
    new = rng.choice(_CASE)
    lines.insert(where + 1, new)
    return f"case control {new!r}"


def _sol(rng: random.Random, lines: list[str]) -> str:
    new = rng.choice(_SOLS)
    for i, ln in enumerate(lines):
        if ln.upper().startswith("SOL"):
            lines[i] = new
            return f"{ln.strip()!r} -> {new!r}"
    lines.insert(0, new)
    return f"insert {new!r}"


def _flip_byte(rng: random.Random, lines: list[str]) -> str:
    i = rng.randrange(len(lines))
    if not lines[i]:
        return "empty line"
    k = rng.randrange(len(lines[i]))
    c = chr(rng.choice([0, 9, 13, 34, 36, 39, 42, 43, 44, 45, 46, 48, 49, 69, 127, 160, 255]))
    lines[i] = lines[i][:k] + c + lines[i][k + 1:]
    return f"line {i + 1} column {k + 1} -> {c!r}"


def _include(rng: random.Random, lines: list[str]) -> str:
    a, b = _bulk_range(lines)
    target = rng.choice(("'/dev/zero'", "'.'", "'missing.inc'", "'/etc/hostname'", "''",
                         "'unterminated", "'ladder_frame.bdf'"))  # fmt: skip
    lines.insert(rng.randint(a, b), f"INCLUDE {target}")
    return f"INCLUDE {target}"


MUTATIONS: tuple[Callable[[random.Random, list[str]], str], ...] = (
    _mutate_field, _mutate_field, _mutate_field, _delete_line, _duplicate_line, _swap_lines,
    _truncate, _plant_card, _case_control, _sol, _flip_byte, _include,
)  # fmt: skip


def mutated_deck(seed: int, decks: list[SeedDeck]) -> tuple[SeedDeck, dict[str, str],
                                                              tuple[str, ...]]:  # fmt: skip
    """The seed deck, mutated files and mutation descriptions of case ``seed``."""
    rng = random.Random(seed)
    deck = decks[rng.randrange(len(decks))]
    files = dict(deck.files)
    name = deck.main if rng.random() < 0.85 or len(files) == 1 else rng.choice(sorted(files))
    lines = files[name].splitlines()
    done = []
    for _ in range(rng.randint(1, 3)):
        if not lines:
            break
        done.append(rng.choice(MUTATIONS)(rng, lines))
    files[name] = "\n".join(lines) + "\n"
    return deck, files, tuple(f"{name}: {d}" for d in done)


# ---------------------------------------------------------------- running


def _modes(path: Path) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        modes, _ = solve_normal_modes(build_model(read_deck(path)))
    return modes.eigenvalues


def same_modes(a: np.ndarray, b: np.ndarray) -> bool:
    """Eigenvalues equal to the solver's precision: 1e-6 relative, with rigid-body roots
    (near zero) compared against the largest one."""
    if a.shape != b.shape:
        return False
    scale = max(float(np.abs(a).max(initial=0.0)), 1e-300)
    return bool(np.all(np.abs(a - b) <= 1e-6 * np.maximum(np.abs(a), 1e-6 * scale)))


def run_case(seed: int, decks: list[SeedDeck], workdir: Path, timeout: float = 20.0) -> Finding:
    """Build, run and classify case ``seed`` in ``workdir`` (emptied first)."""
    for p in workdir.iterdir():
        p.unlink()
    deck, files, mutations = mutated_deck(seed, decks)
    for name, text in files.items():
        (workdir / name).write_text(text, encoding="latin-1")
    t0 = time.perf_counter()
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        with warnings.catch_warnings():  # femcal's warnings are answers too; not counted
            warnings.simplefilter("ignore")
            eig = _modes(workdir / deck.main)
            back = workdir / "written_back.bdf"
            write_deck(read_deck(workdir / deck.main), back)
            again = _modes(back)
        outcome, detail = ("ok", "") if same_modes(eig, again) else (
            "wrong", f"{len(eig)} modes, written back {len(again)}: "
                     f"{eig[:4].tolist()} vs {again[:4].tolist()}")  # fmt: skip
    except _Timeout:
        outcome, detail = "hang", f"past {timeout:g} s"
    except CLEAN as e:
        outcome, detail = "error", f"{type(e).__name__}: {str(e)[:300]}"
    except Exception as e:
        last = traceback.extract_tb(e.__traceback__)[-1]
        outcome = "crash"
        detail = f"{type(e).__name__}: {str(e)[:300]} ({last.filename}:{last.lineno})"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    return Finding(seed, deck.name, mutations, outcome, detail, time.perf_counter() - t0)


def _alarm(signum: int, frame: object) -> None:
    raise _Timeout


def run_deck_fuzz(seed: int, n: int, *, timeout: float = 20.0,
                  progress: Callable[[int, Finding], None] | None = None) -> list[Finding]:  # fmt: skip
    """Run cases ``seed`` .. ``seed + n - 1``; returns every finding."""
    decks = seed_decks()
    out = []
    with tempfile.TemporaryDirectory(prefix="femcal-fuzz-") as tmp:
        work = Path(tmp)
        for k in range(n):
            f = run_case(seed + k, decks, work, timeout)
            out.append(f)
            if progress:
                progress(k, f)
    return out


def iter_counts(findings: list[Finding]) -> Iterator[tuple[str, int]]:
    """(outcome, count) in OUTCOMES order."""
    for o in OUTCOMES:
        yield o, sum(f.outcome == o for f in findings)
