"""Read a NASTRAN deck: executive control, case control and bulk data, with INCLUDEs.

Bulk data formats: small field (8 characters), large field (16, name ending in ``*`` and
``*`` continuation lines), free field (commas; ``NAME*,`` for large free field); tabs
(expanded to 8-column stops); lower case; ``$`` comments (also after data); continuations
by a ``+`` or ``*`` in column 1, or a blank first field. Continuation lines belong to the
card right before them; their column-1 labels are not matched (as in current NASTRAN).

Every problem found is collected with file:line, card and field, and raised together as
one :class:`~femcal.errors.DeckError`.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from ..errors import DeckError, DeckIssue
from .cards import CARDS, UNSUPPORTED_STRUCTURAL
from .deck import Deck, RecordList, canonical_case_key
from .records import RawCard
from .spec import Table

_SMALL = tuple(range(8, 72, 8))
_LARGE = tuple(range(8, 72, 16))
_CEND = re.compile(r"^[ \t]*CEND[ \t\r]*(\$.*)?$", re.IGNORECASE | re.MULTILINE)
_BEGIN_BULK = re.compile(r"^[ \t]*BEGIN[ \t]+(BULK|SUPER)", re.IGNORECASE | re.MULTILINE)
_CASE_CMD = re.compile(r"^\s*([A-Za-z][A-Za-z0-9]*)\s*(\([^)]*\))?\s*=\s*(.*?)\s*$")
_SUBCASE = re.compile(r"^\s*SUBCASE\s+(\d+)\s*$", re.IGNORECASE)

#: Stop collecting after this many problems (the count of the rest is still reported).
MAX_ERRORS = 100


def read_deck(path: str | os.PathLike[str], *, max_errors: int = MAX_ERRORS) -> Deck:
    """Read a NASTRAN deck (or a bulk-data-only file) into a :class:`Deck`.

    Parameters
    ----------
    path : the main input file; INCLUDE paths are resolved relative to the including file.
    max_errors : how many problems to describe before only counting them.

    Raises
    ------
    DeckError
        With every problem found (file:line, card, field, text found, what was expected).
    FileNotFoundError
        If the main file does not exist.
    """
    return _Reader(Path(path), max_errors).run()


class _Reader:
    def __init__(self, path: Path, max_errors: int):
        self.path = path
        self.deck = Deck(path=str(path))
        self.issues: list[DeckIssue] = []
        self.n_issues = 0
        self.max_errors = max_errors
        self.stack: list[Path] = []
        self.section = "bulk"
        self.done = False
        # card being assembled
        self.name: str | None = None
        self.fields: list[str] = []
        # per physical line of the card: (first field index, line number, original text)
        self.field_lines: list[tuple[int, int, str]] = []
        self.file_idx = 0
        self.line0 = 0
        self.in_output_block = False
        self.subcase: int | None = None
        self.pending_case = ""
        self.pending_case_line = 0

    # ------------------------------------------------------------------ top level
    def run(self) -> Deck:
        text = _read_text(self.path)
        if _CEND.search(text):
            self.section = "exec"
        elif _BEGIN_BULK.search(text):
            self.section = "case"
        else:
            self.section = "bulk"
        self._read_file(self.path, text, None)
        self._finish_card()
        self._flush_case()
        for t in self.deck.tables.values():
            t.finish()
        if self.n_issues:
            raise DeckError(self.issues, self.n_issues - len(self.issues))
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
    def _read_file(self, path: Path, text: str | None, include_at: tuple[int, int] | None) -> None:
        real = path.resolve()
        if real in self.stack:
            chain = " -> ".join(str(p) for p in [*self.stack, real])
            f, ln = include_at or (0, 0)
            self.error(f, ln, "INCLUDE", "no INCLUDE cycle", found=chain)
            return
        if text is None:
            try:
                text = _read_text(path)
            except OSError as e:
                f, ln = include_at or (0, 0)
                self.error(f, ln, "INCLUDE", "a readable file", found=f"{path} ({e.strerror})")
                return
        self.deck.files.append(str(path))
        fidx = len(self.deck.files) - 1
        self.stack.append(real)
        try:
            self._read_lines(fidx, path, text.splitlines())
        finally:
            self.stack.pop()

    def _read_lines(self, fidx: int, path: Path, lines: list[str]) -> None:
        n = len(lines)
        i = 0
        while i < n and not self.done:
            raw = lines[i]
            i += 1
            head = raw[:7]
            if head[:1] in "Ii" and head.upper() == "INCLUDE":
                i = self._include(fidx, path, lines, i - 1)
                continue
            if self.section == "bulk":
                # The bulk loop handles many lines at once and returns where it stopped.
                i = self._bulk_lines(fidx, lines, i - 1)
            elif self.section == "exec":
                self._exec_line(fidx, i, raw)
            else:
                self._case_line(fidx, i, raw)

    def _include(self, fidx: int, path: Path, lines: list[str], i: int) -> int:
        """Handle the INCLUDE starting at lines[i]; returns the index after it."""
        self._finish_card()
        line_no = i + 1
        rest = lines[i][7:].split("$")[0].strip()
        if rest.startswith(("'", '"')):
            q = rest[0]
            body = rest[1:]
            j = i
            while q not in body and j + 1 < len(lines):
                j += 1
                body += lines[j].split("$")[0].strip()
            if q not in body:
                self.error(fidx, line_no, "INCLUDE", f"a closing {q} on the file name", found=rest)
                return j + 1
            name = body[: body.index(q)]
            i = j
        else:
            name = rest
        if not name:
            self.error(fidx, line_no, "INCLUDE", "a file name", found=lines[i])
            return i + 1
        target = Path(name)
        if not target.is_absolute():
            target = path.parent / target
        self._read_file(target, None, (fidx, line_no))
        return i + 1

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
                self.error(fidx, line_no, "SOL", "a solution number or name (e.g. 103, SEMODES)",
                           found=s.strip())

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
                self.error(fidx, line_no, "BEGIN SUPER", "BEGIN BULK (superelements are not supported)",
                           found=s.strip())
                self.done = True
                return
        self.deck.case.lines.append(s)
        if self.in_output_block:
            return
        if self.pending_case:
            self.pending_case += " " + s.strip()
        else:
            self.pending_case, self.pending_case_line = s.strip(), line_no
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
            # OUTPUT(PLOT) / OUTPUT(XYPLOT) blocks: plotter commands until BEGIN BULK.
            self.in_output_block = "PLOT" in up
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

    # ------------------------------------------------------------------ bulk
    def _bulk_lines(self, fidx: int, lines: list[str], i: int) -> int:
        """Read bulk lines from lines[i]; return the index of the first line not consumed."""
        n = len(lines)
        fields = self.fields
        while i < n:
            raw = lines[i]
            i += 1
            k = raw.find("$")
            if k >= 0:
                raw = raw[:k]
            s = raw.rstrip()
            if not s:
                continue
            c0 = s[0]
            if c0 in "Ii" and s[:7].upper() == "INCLUDE":
                return i - 1
            if "\t" in s:
                s = s.expandtabs(8)
                c0 = s[0]
            original = s
            s = s.upper()
            if "," in s:
                parts = s.split(",")
                head = parts[0].strip()
                large = head.endswith("*")
                cont = not head or head[0] in "+*"
                width = 4 if large or (cont and head.startswith("*")) else 8
                data = [p.strip() for p in parts[1 : width + 1]]
                extra = [p for p in parts[width + 2 :] if p.strip()]
                if extra:
                    self.error(fidx, i, head.rstrip("*") if not cont else (self.name or ""),
                               f"at most {width} data fields and a continuation field on a "
                               "free-field line", found=",".join(extra))
                if len(data) < width:
                    data += [""] * (width - len(data))
            else:
                head = s[:8].strip()
                cont = not head or c0 in "+*"
                large = head.endswith("*") if not cont else c0 == "*"
                if len(s) > 80 and s[80:].strip():
                    self.error(fidx, i, head or (self.name or ""), "nothing after column 80",
                               found=s[80:].strip())
                if large:
                    data = [s[8:24].strip(), s[24:40].strip(), s[40:56].strip(), s[56:72].strip()]
                    width = 4
                else:
                    data = [
                        s[8:16].strip(), s[16:24].strip(), s[24:32].strip(), s[32:40].strip(),
                        s[40:48].strip(), s[48:56].strip(), s[56:64].strip(), s[64:72].strip(),
                    ]  # fmt: skip
                    width = 8
            if cont:
                if self.name is None:
                    self.error(fidx, i, "", "a card name in field 1 (continuation line with no card "
                               "before it)", found=s.strip())
                    continue
                if width == 8 and len(fields) % 8:
                    fields.extend([""] * (8 - len(fields) % 8))
            else:
                self._finish_card()
                name = head.rstrip("*")
                if name == "ENDDATA":
                    self.done = True
                    return n
                if name.startswith("BEGIN") and s.split()[:2] == ["BEGIN", "BULK"]:
                    continue
                self.name = name
                self.file_idx = fidx
                self.line0 = i
                fields = self.fields = []
                self.field_lines = []
            self.field_lines.append((len(fields), i, original))
            fields.extend(data)
        return n

    def _finish_card(self) -> None:
        name = self.name
        if name is None:
            return
        self.name = None
        fields = self.fields
        while fields and not fields[-1]:
            fields.pop()
        deck = self.deck
        deck.card_count[name] = deck.card_count.get(name, 0) + 1
        d = CARDS.get(name)
        fidx, line0 = self.file_idx, self.line0
        if d is None:
            if name in UNSUPPORTED_STRUCTURAL:
                self.error(fidx, line0, name, f"a supported card ({name} is "
                           f"{UNSUPPORTED_STRUCTURAL[name]}; it would change the SOL 103 answer)")
            elif not _is_card_name(name):
                self.error(fidx, line0, name, "a card name (letters and digits, starting with a "
                           "letter)", found=name, field=1)
            else:
                deck.unused.append(RawCard(name, tuple(fields)), fidx, line0)
            return
        errors: list[tuple[int, str, str]] = []
        if d.layout is not None:
            table = deck.tables.get(name)
            if table is None:
                table = deck.tables[name] = Table(d.layout)
            if d.multi is None:
                row = d.layout.parse(fields, errors)
                if row is not None:
                    table.append(row, fidx, line0)
            else:
                shared, width, per_card = d.multi
                head = fields[:shared]
                for e in range(per_card):
                    start = shared + e * width
                    part = fields[start : start + width]
                    if not any(part):
                        if e == 0:
                            errors.append((start, "", "at least one entry"))
                        continue
                    sub: list[tuple[int, str, str]] = []
                    row = d.layout.parse(head + part, sub)
                    errors.extend((k if k < shared else k - shared + start, s, x) for k, s, x in sub)
                    if row is not None:
                        table.append(row, fidx, line0)
                for k in range(shared + per_card * width, len(fields)):
                    if fields[k]:
                        errors.append((k, fields[k], f"at most {per_card} entries"))
                        break
        else:
            assert d.record is not None
            obj = d.record(fields, errors)
            if not errors:
                rl = deck.records.get(name)
                if rl is None:
                    rl = deck.records[name] = RecordList()
                rl.append(obj, fidx, line0)
        for k, text, expected in errors:
            label = None
            if d.layout is not None:
                slots = d.layout.slots
                shared, width = d.multi[:2] if d.multi else (0, 0)
                kk = k if not d.multi or k < shared else shared + (k - shared) % width
                if kk < len(slots):
                    label = slots[kk].label
            line, original = self._line_of(k)
            # Show the text as written (fields were upper-cased for reading).
            at = original.upper().find(text) if text else -1
            found = original[at : at + len(text)] if at >= 0 else text
            self.error(fidx, line, name, expected, found=found, field=k % 8 + 2, name=label)

    def _line_of(self, k: int) -> tuple[int, str]:
        """Line number and original text of the physical line holding data field k."""
        line, text = self.line0, ""
        for start, ln, original in self.field_lines:
            if start > k:
                break
            line, text = ln, original
        return line, text


def _is_card_name(name: str) -> bool:
    return bool(name) and name[0].isalpha() and name.isalnum() and name.isascii()


def _read_text(path: Path) -> str:
    # latin-1 never fails; non-ASCII text in a data field is then reported by the field reader.
    return path.read_bytes().decode("latin-1")
