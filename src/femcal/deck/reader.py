"""Read a NASTRAN deck: executive control, case control and bulk data, with INCLUDEs.

Bulk data formats: small field (8 characters), large field (16, name ending in ``*`` and
``*`` continuation lines), free field (commas; ``NAME*,`` for large free field); tabs
(expanded to 8-column stops); lower case; ``$`` comments (also after data); continuations
by a ``+`` or ``*`` in column 1, or a blank first field. Continuation lines belong to the
card right before them; their column-1 labels are not matched (as in current NASTRAN).
Older field conventions that NASTRAN still reads (the integer orientation flag in CBAR field
9, ...) are turned into their current form before a card's fields are typed
(:mod:`femcal.deck.legacy`).

Every problem found is collected with file:line, card and field, and raised together as
one :class:`~femcal.errors.DeckError`.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import re
import stat
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TextIO

from ..errors import DeckError, DeckIssue, FemcalWarning
from .cards import CARDS, UNSUPPORTED_STRUCTURAL, CardDef
from .deck import (
    MODAL_COMMANDS,
    Deck,
    RecordList,
    canonical_case_key,
    is_case_command,
    nearest_case_command,
)
from .fastlane import FastGroup, split_block
from .records import RawCard
from .spec import CHUNK, FAST_FAILURES, Layout, Table

_SMALL = tuple(range(8, 72, 8))
_LARGE = tuple(range(8, 72, 16))
_CEND = re.compile(r"^[ \t]*CEND[ \t]*(\$.*)?$", re.IGNORECASE | re.MULTILINE)
_BEGIN_BULK = re.compile(r"^[ \t]*BEGIN[ \t]+(BULK|SUPER)", re.IGNORECASE | re.MULTILINE)
_CASE_CMD = re.compile(r"^\s*([A-Za-z][A-Za-z0-9]*)\s*(\([^)]*\))?\s*=\s*(.*?)\s*$")
_ASCII_UPPER = str.maketrans("abcdefghijklmnopqrstuvwxyz", "ABCDEFGHIJKLMNOPQRSTUVWXYZ")
_CASE_WORD = re.compile(r"^\s*([A-Za-z][A-Za-z0-9]*)")
_SUBCASE = re.compile(r"^\s*SUBCASE\s+(\d+)\s*$", re.IGNORECASE)

#: Stop collecting after this many problems (the count of the rest is still reported).
MAX_ERRORS = 100
#: The most bytes a deck may hold, its INCLUDEs with it (the largest decks in use are a few
#: GB; a file past this is more likely a mistake than a model).
MAX_DECK_BYTES = 16 * 1024**3


def read_deck(
    path: str | os.PathLike[str], *, max_errors: int = MAX_ERRORS, fast_lane: bool = True,
    max_bytes: int = MAX_DECK_BYTES,
) -> Deck:
    """Read a NASTRAN deck (or a bulk-data-only file) into a :class:`Deck`.

    Parameters
    ----------
    path : the main input file; INCLUDE paths are resolved relative to the including file.
    max_errors : how many problems to describe before only counting them.
    fast_lane : read one-line small-field cards with NumPy (:mod:`femcal.deck.fastlane`).
        The result is the same either way; False reads every card field by field.
    max_bytes : the most bytes the main file and its INCLUDEs may hold together.

    Only regular files are read (an INCLUDE of ``/dev/zero`` or a pipe would never end).

    Raises
    ------
    DeckError
        With every problem found (file:line, card, field, text found, what was expected),
        a main file or INCLUDE that is not a regular file, or a deck past ``max_bytes``.
    FileNotFoundError
        If the main file does not exist.
    """
    path = Path(path)
    problem = _not_readable(path, max_bytes)
    if problem:
        raise DeckError([DeckIssue(str(path), 0, "", None, None, None, problem)])
    reader = _Reader(path, max_errors, FAST_LAYOUTS if fast_lane else {})
    reader.bytes_left = max_bytes - path.stat().st_size
    return reader.run()


def _not_readable(path: Path, max_bytes: int) -> str:
    """Why ``path`` cannot be read as a deck file (not regular, or larger than ``max_bytes``),
    ``""`` if it can. A missing file raises FileNotFoundError."""
    if "\0" in str(path):
        return "a file name without NUL characters"
    st = path.stat()
    if not stat.S_ISREG(st.st_mode):
        return "a regular file (not a device, pipe or directory)"
    if st.st_size > max_bytes:
        return (f"a deck of at most {max_bytes} bytes with its INCLUDEs "
                f"(this file has {st.st_size})")  # fmt: skip
    kind = _other_kind(path)
    if kind:
        return f"a NASTRAN deck (text cards), not {kind}"
    return ""


#: Files femcal reads elsewhere, by suffix: what they are and which command reads them
#: (named when the content shows a file is not a deck; a .toml is never one).
OTHER_KINDS = {
    ".uff": "a universal file (FRFs or shapes: femcal identify or correlate reads it)",
    ".unv": "a universal file (FRFs or shapes: femcal identify or correlate reads it)",
    ".mat": "a MATLAB file (FRFs: femcal identify reads it)",
    ".npz": "a NumPy archive (FRFs, time data, modes or an identified model)",
    ".rsp": "an RPC III time history (femcal timedata reads it)",
    ".tim": "an RPC III time history (femcal timedata reads it)",
    ".drv": "an RPC III drive file (femcal timedata and femcal rig read it)",
    ".toml": "a configuration (femcal calibrate or study reads it)",
}


#: Bytes no text deck holds (ASCII controls but tab, line feed, form feed, carriage return).
_CONTROL_BYTES = bytes([*range(0, 9), 11, *range(14, 32), 127])


def _other_kind(path: Path) -> str:
    """What ``path`` is when it is plainly not a NASTRAN deck ("" when it may be one): binary
    data (control bytes other than whitespace, 5 % of its first 64 kB, of at least 4 kB;
    stray ones in a text deck are reported at their cards), a universal file's dataset delimiter
    ("-1" alone on its first line), or a configuration; named by its suffix where femcal
    reads that kind."""
    suffix = path.suffix.lower()
    if suffix == ".toml":
        return OTHER_KINDS[suffix]
    with path.open("rb") as f:
        head = f.read(65536)
    control = len(head) - len(head.translate(None, _CONTROL_BYTES))
    if len(head) >= 4096 and control >= len(head) // 20:
        return OTHER_KINDS.get(suffix, "a text file: it holds binary data")
    if head.lstrip(b"\r\n").split(b"\n", 1)[0].strip() == b"-1":
        return OTHER_KINDS[".uff"]
    return ""


class _Reader:
    def __init__(self, path: Path, max_errors: int, fast_layouts: dict[str, Layout]):
        self.path = path
        self.deck = Deck(path=str(path))
        self.issues: list[DeckIssue] = []
        self.n_issues = 0
        self.max_errors = max_errors
        self.fast_layouts = fast_layouts
        self.stack: list[Path] = []
        self.section = "bulk"
        self.done = False
        # card being assembled
        self.name: str | None = None
        self.fields: list[str] = []
        # per physical line of the card: (first field index, line number)
        self.field_lines: list[tuple[int, int]] = []
        self.file_idx = 0
        self.line0 = 0
        self.handlers: dict[str, Callable[[list[str]], None]] = {}
        # reading order: line i of the current file is line (shift + i) of everything read
        self.shift = 0
        self.total = 0
        self.seq0 = 0  # reading-order number of the current card's first line
        self.first_seen: dict[str, int] = {}
        self.in_output_block = False
        self.subcase: int | None = None
        self.pending_case = ""
        self.pending_case_line = 0
        self.pending_case_file = 0
        self.bytes_left = MAX_DECK_BYTES  # what the INCLUDEs still may hold

    # ------------------------------------------------------------------ top level
    def run(self) -> Deck:
        self.section = _first_section(self.path)
        self._read_file(self.path, None)
        self._finish_card()
        self._flush_case()
        for t in self.deck.tables.values():
            t.finish()
        # cards in the order they first appear (the fast lane counts a block at a time)
        counts = self.deck.card_count
        order = sorted(counts, key=lambda n: self.first_seen.get(n, 0))
        self.deck.card_count = {n: counts[n] for n in order}
        if self.n_issues:
            raise DeckError(_as_written(self.issues), self.n_issues - len(self.issues))
        return self.deck

    def error(
        self,
        file: int,
        line: int,
        card: str,
        expected: str,
        found: str | None = None,
        field: int | None = None,
        name: str | None = None,
    ) -> None:
        self.n_issues += 1
        if len(self.issues) < self.max_errors:
            self.issues.append(
                DeckIssue(self.deck.files[file], line, card, field, name, found, expected)
            )

    # ------------------------------------------------------------------ files
    def _read_file(self, path: Path, include_at: tuple[int, int] | None) -> None:
        if include_at is not None and "\0" in str(path):
            self.error(*include_at, "INCLUDE", "a file name without NUL characters",
                       found=str(path))  # fmt: skip
            return
        real = path.resolve()
        if real in self.stack:
            chain = " -> ".join(str(p) for p in [*self.stack, real])
            f, ln = include_at or (0, 0)
            self.error(f, ln, "INCLUDE", "no INCLUDE cycle", found=chain)
            return
        if include_at is not None:
            f, ln = include_at
            try:
                problem = _not_readable(path, self.bytes_left)
            except OSError as e:
                problem = f"a readable file ({e.strerror})"
            if problem:
                self.error(f, ln, "INCLUDE", problem, found=str(path))
                return
            self.bytes_left -= path.stat().st_size
        try:
            # latin-1 never fails; non-ASCII text in a data field is reported by its reader.
            fh = open(path, encoding="latin-1", newline=None)  # noqa: SIM115 - closed below
        except OSError as e:
            if include_at is None:
                raise
            f, ln = include_at
            self.error(f, ln, "INCLUDE", "a readable file", found=f"{path} ({e.strerror})")
            return
        self.deck.files.append(str(path))
        fidx = len(self.deck.files) - 1
        self.stack.append(real)
        outer_shift = self.shift
        self.shift = self.total  # line i of this file is the (shift + i)-th line read
        lines = _Lines(fh)
        try:
            with fh:
                self._read_lines(fidx, path, lines)
        finally:
            self.stack.pop()
            self.total = self.shift + lines.n
            self.shift = outer_shift

    def _read_lines(self, fidx: int, path: Path, lines: _Lines) -> None:
        while not self.done:
            # The bulk loop reads many lines; it returns at an INCLUDE or the end.
            raw = self._bulk_lines(fidx, lines) if self.section == "bulk" else lines.next()
            if raw is None:
                return
            if raw[:1] in "Ii" and raw[:7].upper() == "INCLUDE":
                self._include(fidx, path, lines, raw)
            elif self.section == "exec":
                self._exec_line(fidx, lines.n, raw)
            elif self.section == "case":
                self._case_line(fidx, lines.n, raw)

    def _include(self, fidx: int, path: Path, lines: _Lines, raw: str) -> None:
        """Handle an INCLUDE line (its quoted name may continue on the next lines)."""
        self._finish_card()
        line_no = lines.n
        rest = raw[7:].split("$")[0].strip()
        if rest.startswith(("'", '"')):
            q = rest[0]
            body = rest[1:]
            while q not in body:
                more = lines.next()
                if more is None:
                    self.error(
                        fidx, line_no, "INCLUDE", f"a closing {q} on the file name", found=rest
                    )
                    return
                body += more.split("$")[0].strip()
            name = body[: body.index(q)]
        else:
            name = rest
        if not name:
            self.error(fidx, line_no, "INCLUDE", "a file name", found=raw.strip())
            return
        target = Path(name)
        if not target.is_absolute():
            target = path.parent / target
        self.total = self.shift + lines.n  # everything read before the included file
        self._read_file(target, (fidx, line_no))
        self.shift = self.total - lines.n  # lines after the INCLUDE come after the included

    # ------------------------------------------------------------------ executive / case
    def _exec_line(self, fidx: int, line_no: int, raw: str) -> None:
        s = raw.split("$")[0].rstrip()
        if not s.strip():
            return
        word = s.split(None, 1)[0].upper().rstrip(",")
        if word.startswith("CEND"):
            self.section = "case"
            return
        self.deck.executive.append(s.strip())
        if word.startswith("SOL"):
            self.deck.set_sol(s)
            if self.deck.sol is None:
                self.error(
                    fidx,
                    line_no,
                    "SOL",
                    "a solution number or name (e.g. 103, SEMODES)",
                    found=s.strip(),
                )

    def _case_line(self, fidx: int, line_no: int, raw: str) -> None:
        s = raw.split("$")[0].rstrip()
        if not s.strip():
            return
        up = s.strip().upper()
        if up.startswith("BEGIN"):
            self._flush_case()
            words = up.split()
            if len(words) >= 2 and words[1].startswith("BULK"):
                self.section = "bulk"
                self.deck.has_bulk_section = True
                return
            if len(words) >= 2 and words[1].startswith("SUPER"):
                self.error(
                    fidx,
                    line_no,
                    "BEGIN SUPER",
                    "BEGIN BULK (superelements are not supported)",
                    found=s.strip(),
                )
                self.done = True
                return
        self.deck.case.lines.append(s)
        if self.in_output_block:
            return
        if self.pending_case:
            self.pending_case += " " + s.strip()
        else:
            self.pending_case, self.pending_case_line = s.strip(), line_no
            self.pending_case_file = fidx
        if self.pending_case.endswith(","):
            return
        self._flush_case()

    def _flush_case(self) -> None:
        text, self.pending_case = self.pending_case, ""
        if not text:
            return
        m = _SUBCASE.match(text)
        if m:
            self.subcase = int(m.group(1))
            self.deck.case.subcases.setdefault(self.subcase, {})
            return
        up = text.upper()
        if up.startswith("OUTPUT") and "(" in up and "=" not in up:
            # OUTPUT(PLOT), (XYPLOT) and (XYOUT) blocks: plotter commands until BEGIN BULK.
            self.in_output_block = "PLOT" in up or "XYOUT" in up
            return
        word = _CASE_WORD.match(text)
        if word and not is_case_command(word.group(1)):
            modal = nearest_case_command(word.group(1), MODAL_COMMANDS)
            misplaced = _misplaced(word.group(1))
            if misplaced:  # a bulk card or an executive statement in case control
                self.error(self.pending_case_file, self.pending_case_line, "CASE CONTROL",
                           misplaced, found=word.group(1), name="command")  # fmt: skip
            elif modal:  # SCP for SPC: the answer would change without a word
                self.error(self.pending_case_file, self.pending_case_line, "CASE CONTROL",
                           f"a case control command (did you mean {modal}?)",
                           found=word.group(1), name="command")  # fmt: skip
            else:
                where = self.deck.where(self.pending_case_file, self.pending_case_line)
                warnings.warn(FemcalWarning(
                    f"{where}: case control command {word.group(1)} is not one femcal knows; "
                    "it is left alone (it does not look like one that changes the normal "
                    "modes)"), stacklevel=2)  # fmt: skip
            return
        m = _CASE_CMD.match(text)
        if not m:
            return  # commands without '=' (e.g. "ECHO", "OUTPUT") are kept as text only
        key = canonical_case_key(m.group(1))
        value = m.group(3)
        if key in ("TITLE", "SUBTITLE", "LABEL"):
            value = text.split("=", 1)[1].strip()
        target = (
            self.deck.case.global_
            if self.subcase is None
            else self.deck.case.subcases[self.subcase]
        )
        target[key] = value
        self.deck.case.where[(self.subcase, key)] = (self.pending_case_file,
                                                     self.pending_case_line)  # fmt: skip

    # ------------------------------------------------------------------ bulk
    def _bulk_lines(self, fidx: int, lines: _Lines) -> str | None:
        """Read bulk lines in blocks; return an INCLUDE line (unread), or None at the end.

        Each block goes through the fast lane (:mod:`femcal.deck.fastlane`) first; what it
        leaves is read line by line by :meth:`_slow_lines`.
        """
        while not self.done:
            block = lines.block(BLOCK_LINES)
            if not block:
                return None
            split = split_block(block, lines.at_end(), self.fast_layouts)
            stop = split.stop
            if stop is not None:
                lines.unread(block[stop:])
                block = block[:stop]
            base = lines.n - len(block)
            for g in split.groups:
                self._add_fast(fidx, g, base)
            if len(split.slow):
                self._slow_lines(fidx, ((base + j + 1, block[j]) for j in split.slow.tolist()))
            if stop is not None and not self.done:
                raw = lines.next()
                assert raw is not None
                if raw[:7].upper() == "INCLUDE":
                    return raw
                self._slow_lines(fidx, [(lines.n, raw)])  # ENDDATA
        return None

    def _add_fast(self, fidx: int, g: FastGroup, base: int) -> None:
        """Store a group of cards read by the fast lane."""
        table = self.deck.tables.get(g.name)
        if table is None:
            table = self.deck.tables[g.name] = Table(self.fast_layouts[g.name])
        seq = self.shift + base + 1 + g.lines
        table.add_chunk(g.columns, fidx, base + 1 + g.lines, seq)
        counts = self.deck.card_count
        counts[g.name] = counts.get(g.name, 0) + len(g.lines)
        first = int(seq[0])
        if first < self.first_seen.get(g.name, first + 1):
            self.first_seen[g.name] = first

    def _slow_lines(self, fidx: int, numbered: Iterable[tuple[int, str]]) -> None:
        """Read (line number, text) pairs field by field. Cards may span calls.

        This is the hot loop of the slow lane: written for speed (locals, no helper calls
        for the common small-field line).
        """
        fields = self.fields
        field_lines = self.field_lines
        counts = self.deck.card_count
        handlers = self.handlers
        first_seen = self.first_seen
        name = self.name
        for i, raw in numbered:
            if "$" in raw:
                raw = raw[: raw.index("$")]
            s = raw.rstrip()
            if not s:
                continue
            c0 = s[0]
            if "\t" in s:
                s = s.expandtabs(8)
                c0 = s[0]
            # ASCII letters only: str.upper() maps latin-1 text outside latin-1 ('ÿ' -> 'Ÿ'),
            # which the deck writer could not write back
            s = s.upper() if s.isascii() else s.translate(_ASCII_UPPER)
            if "," in s:
                parts = s.split(",")
                head = parts[0].strip()
                large = head.endswith("*")
                cont = not head or head[0] in "+*"
                width = 4 if large or (cont and head.startswith("*")) else 8
                data = [p.strip() for p in parts[1 : width + 1]]
                extra = [p for p in parts[width + 2 :] if p.strip()]
                if extra:
                    self.error(
                        fidx,
                        i,
                        head.rstrip("*") if not cont else (name or ""),
                        f"at most {width} data fields and a continuation field on a "
                        "free-field line",
                        found=",".join(extra),
                    )
                if len(data) < width:
                    data += [""] * (width - len(data))
            else:
                head = s[:8].strip()
                cont = not head or c0 in "+*"
                if len(s) > 80 and s[80:].strip():
                    self.error(
                        fidx,
                        i,
                        head or (name or ""),
                        "nothing after column 80",
                        found=s[80:].strip(),
                    )
                if (c0 == "*") if cont else head.endswith("*"):
                    data = [s[8:24].strip(), s[24:40].strip(), s[40:56].strip(), s[56:72].strip()]
                    width = 4
                else:
                    data = [
                        s[8:16].strip(), s[16:24].strip(), s[24:32].strip(), s[32:40].strip(),
                        s[40:48].strip(), s[48:56].strip(), s[56:64].strip(), s[64:72].strip(),
                    ]  # fmt: skip
                    width = 8
            if cont:
                if name is None:
                    self.error(
                        fidx,
                        i,
                        "",
                        "a card name in field 1 (continuation line with no card before it)",
                        found=s.strip(),
                    )
                    continue
                if width == 8 and len(fields) % 8:
                    fields.extend([""] * (8 - len(fields) % 8))
                field_lines.append((len(fields), i))
                fields.extend(data)
                continue
            if name is not None:
                # Finish the card before this line (inlined _finish_card).
                while fields and not fields[-1]:
                    fields.pop()
                counts[name] = counts.get(name, 0) + 1
                if first_seen.get(name, self.seq0 + 1) > self.seq0:  # (a fast card may be later)
                    first_seen[name] = self.seq0
                handler = handlers.get(name)
                if handler is None:
                    handler = handlers[name] = self._handler(name)
                self.fields, self.field_lines = fields, field_lines
                handler(fields)
            name = head.rstrip("*")
            if name == "ENDDATA":
                self.name = None
                self.done = True
                return
            if name.startswith("BEGIN") and s.split()[:2] == ["BEGIN", "BULK"]:
                name = None
                continue
            self.name = name
            self.file_idx = fidx
            self.line0 = i
            self.seq0 = self.shift + i
            fields = data
            field_lines = [(0, i)]
        self.name, self.fields, self.field_lines = name, fields, field_lines

    def _finish_card(self) -> None:
        name = self.name
        if name is None:
            return
        self.name = None
        fields = self.fields
        while fields and not fields[-1]:
            fields.pop()
        counts = self.deck.card_count
        counts[name] = counts.get(name, 0) + 1
        if self.first_seen.get(name, self.seq0 + 1) > self.seq0:
            self.first_seen[name] = self.seq0
        handler = self.handlers.get(name)
        if handler is None:
            handler = self.handlers[name] = self._handler(name)
        handler(fields)

    def _handler(self, name: str) -> Callable[[list[str]], None]:
        """The function that stores one card of this name (made once per name)."""
        deck = self.deck
        d = CARDS.get(name)
        if d is None:
            if name in UNSUPPORTED_STRUCTURAL:
                why = UNSUPPORTED_STRUCTURAL[name]

                def unsupported(fields: list[str]) -> None:
                    self.error(
                        self.file_idx,
                        self.line0,
                        name,
                        f"a supported card ({name} is {why}; it would change the SOL 103 answer)",
                    )

                return unsupported
            if not _is_card_name(name):

                def bad_name(fields: list[str]) -> None:
                    self.error(
                        self.file_idx,
                        self.line0,
                        name,
                        "a card name (letters and digits, starting with a letter)",
                        found=name,
                        field=1,
                    )

                return bad_name

            def unused(fields: list[str]) -> None:
                deck.unused.append(RawCard(name, tuple(fields)), self.file_idx, self.line0)

            return unused
        if d.record is not None:
            parse_record = d.record
            records = deck.records.setdefault(name, RecordList())

            def record(fields: list[str]) -> None:
                errors: list[tuple[int, str, str]] = []
                obj = parse_record(fields, errors)
                if errors:
                    self._report(d, name, errors)
                else:
                    records.append(obj, self.file_idx, self.line0)

            return record
        layout = d.layout
        assert layout is not None
        table = deck.tables.setdefault(name, Table(layout))
        append = table.append
        if d.multi is None:
            fast = layout.fast
            pending = table.pending

            def row(fields: list[str]) -> None:
                try:
                    pending.append(fast(fields, self.file_idx, self.line0, self.seq0))
                except FAST_FAILURES:
                    errors: list[tuple[int, str, str]] = []
                    r = layout.parse_checked(fields, errors)
                    if errors:
                        self._report(d, name, errors)
                        return
                    append(r, self.file_idx, self.line0, self.seq0)
                if len(pending) >= CHUNK:
                    table.flush()

            rewrite = d.rewrite
            if rewrite is None:
                return row

            def rewritten(fields: list[str]) -> None:
                # Older field conventions in their current form first (femcal.deck.legacy).
                # The fast lane never takes these cards' rewritten fields: it leaves every
                # non-blank word field (OFFT) to this reader.
                errors = rewrite(name, fields)
                if not errors:
                    row(fields)
                    return
                rest = list(fields)
                for k, _, _ in errors:
                    rest[k] = ""
                layout.parse_checked(rest, errors)  # the card's other problems too
                self._report(d, name, sorted(errors, key=lambda e: e[0]))

            return rewritten

        shared, width, per_card = d.multi

        def rows(fields: list[str]) -> None:
            errors: list[tuple[int, str, str]] = []
            head = fields[:shared]
            for e in range(per_card):
                start = shared + e * width
                part = fields[start : start + width]
                if not any(part):
                    if e == 0:
                        errors.append((start, "", "at least one entry"))
                    continue
                sub: list[tuple[int, str, str]] = []
                r = layout.parse(head + part, sub)
                errors.extend((k if k < shared else k - shared + start, s, x) for k, s, x in sub)
                if r is not None:
                    append(r, self.file_idx, self.line0, self.seq0)
            for k in range(shared + per_card * width, len(fields)):
                if fields[k]:
                    errors.append((k, fields[k], f"at most {per_card} entries"))
                    break
            if errors:
                self._report(d, name, errors)

        return rows

    def _report(self, d: CardDef, name: str, errors: list[tuple[int, str, str]]) -> None:
        """Record a card's problems with the line, field number and QRG name of each."""
        for k, text, expected in errors:
            label = None
            if d.layout is not None:
                slots = d.layout.slots
                shared, width = d.multi[:2] if d.multi else (0, 0)
                kk = k if not d.multi or k < shared else shared + (k - shared) % width
                if kk < len(slots):
                    label = slots[kk].label
            self.error(
                self.file_idx,
                self._line_of(k),
                name,
                expected,
                found=text,
                field=k % 8 + 2,
                name=label,
            )

    def _line_of(self, k: int) -> int:
        """Line number of the physical line holding data field k of the current card."""
        line = self.line0
        for start, ln in self.field_lines:
            if start > k:
                break
            line = ln
        return line


#: Lines handed to the fast lane at a time.
BLOCK_LINES = 32768

#: Cards the fast lane may read: fixed table layouts with one entry per card.
FAST_LAYOUTS = {n: d.layout for n, d in CARDS.items() if d.layout is not None and d.multi is None}


def _as_written(issues: list[DeckIssue]) -> list[DeckIssue]:
    """Issues with the ``found`` text in its original case (fields are read upper-cased).

    Reads each file involved once, up to the last line needed.
    """
    wanted: dict[str, set[int]] = {}
    for i in issues:
        if i.found:
            wanted.setdefault(i.file, set()).add(i.line)
    text: dict[tuple[str, int], str] = {}
    for path, numbers in wanted.items():
        last = max(numbers)
        try:
            with open(path, encoding="latin-1", newline=None) as fh:
                for n, line in enumerate(fh, 1):
                    if n in numbers:
                        text[path, n] = line.rstrip("\n").split("$")[0].expandtabs(8)
                    if n >= last:
                        break
        except OSError:
            continue
    out = []
    for i in issues:
        original = text.get((i.file, i.line), "")
        at = original.upper().find(i.found) if i.found else -1
        if at >= 0:
            i = dataclasses.replace(i, found=original[at : at + len(i.found)])
        out.append(i)
    return out


#: Executive control statements (they end at CEND).
_EXECUTIVE = frozenset({"SOL", "CEND", "ID", "TIME", "DIAG", "APP", "COMPILE", "ALTER",
                        "NASTRAN", "INIT", "ASSIGN", "GEOMCHECK", "DOMAINSOLVER"})


def _misplaced(word: str) -> str:
    """What a case-control line that starts with ``word`` was meant to be, when it is a bulk
    data card or an executive statement (a line left before BEGIN BULK or after CEND):
    the error's "expected" text, ``""`` otherwise."""
    up = word.upper()
    if up in CARDS or up in UNSUPPORTED_STRUCTURAL or up == "ENDDATA":
        return "a case control command (a bulk data card belongs after BEGIN BULK)"
    if up in _EXECUTIVE:
        return "a case control command (executive control belongs before CEND)"
    return ""


def _is_card_name(name: str) -> bool:
    return bool(name) and name[0].isalpha() and name.isalnum() and name.isascii()


class _Lines:
    """A file's lines as a stream, with the number of the last line handed out (``n``)."""

    def __init__(self, fh: TextIO):
        self._it: Iterator[str] = _chunked_lines(fh)
        self._back: list[str] = []  # lines given back, next first (reversed)
        self.n = 0

    def next(self) -> str | None:
        if self._back:
            self.n += 1
            return self._back.pop()
        for line in self._it:
            self.n += 1
            return line
        return None

    def block(self, size: int) -> list[str]:
        """Up to ``size`` next lines."""
        out = self._back[::-1][:size]
        del self._back[len(self._back) - len(out) :]
        if len(out) < size:
            out.extend(itertools.islice(self._it, size - len(out)))
        self.n += len(out)
        return out

    def unread(self, lines: list[str]) -> None:
        """Give lines back; they come out again next."""
        self._back.extend(reversed(lines))
        self.n -= len(lines)

    def at_end(self) -> bool:
        if self._back:
            return False
        for line in self._it:
            self._back.append(line)
            return False
        return True


def _chunked_lines(fh: TextIO, size: int = 1 << 22) -> Iterator[str]:
    """Lines of a text file (universal newlines), read in large chunks for speed."""
    tail = ""
    while True:
        chunk = fh.read(size)
        if not chunk:
            break
        parts = (tail + chunk).split("\n")
        tail = parts.pop()
        yield from parts
    if tail:
        yield tail


def _first_section(path: Path) -> str:
    """Where the main file starts: 'exec' if it has a CEND line, 'case' if it has BEGIN BULK
    but no CEND, else 'bulk' (a bulk-data-only file). Scans in chunks, stopping at the first
    CEND or BEGIN BULK, so a large bulk file is never held in memory."""
    tail = ""
    with open(path, encoding="latin-1", newline=None) as fh:
        while True:
            chunk = fh.read(1 << 22)
            if not chunk:
                return "bulk"
            text = tail + chunk
            cend, bulk = _CEND.search(text), _BEGIN_BULK.search(text)
            if cend and (not bulk or cend.start() < bulk.start()):
                return "exec"
            if bulk:
                return "case"
            tail = text[-200:]
