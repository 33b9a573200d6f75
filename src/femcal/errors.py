"""Errors raised by femcal.

Every error says *what* went wrong, *where* (file:line, card, field, id) and *what was
expected*. The library raises these; only the CLI prints them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


class FemcalError(Exception):
    """Base class of every error femcal raises on purpose."""


class FemcalWarning(UserWarning):
    """Something the user should know that does not stop the work (a SOL femcal solves as
    SOL 103, a request capped at what the model has). Issued with :func:`warnings.warn`; the
    CLI prints each as one line."""


class ConfigError(FemcalError, ValueError):
    """A calibration configuration or parameter file that cannot be used: the message names
    the file, the table and key (or the parameter), what was found and what was expected.
    A :class:`ValueError` too, so that callers catching ValueError keep working."""


class FRFError(FemcalError, ValueError):
    """FRF data that cannot be used: a file that is not what its suffix says, or a data set
    that breaks what an FRF set is (finite, strictly increasing frequencies; finite complex
    values on a complete outputs x inputs grid; channels that measured something). The
    message names the file (or the data set), where in it (line, dataset, variable), the
    channel and what was expected. A ValueError as well, so that callers which catch
    ValueError for bad input keep doing so."""


class TimeDataError(FemcalError, ValueError):
    """Time histories that cannot be used: a file that breaks its format (RPC III header
    keywords, data size) or data that break what a time history is. The message names the
    file, the keyword or channel, and what was expected."""


class DriveLimitError(FemcalError):
    """A drive beyond its actuators' limits, refused as the user chose: the message names
    each actuator, the quantity (stroke, velocity, acceleration), the peak and the limit."""


class ResourceError(FemcalError):
    """A request would need more memory (or another resource) than the machine has; raised
    before allocating."""


def message(error: Exception) -> str:
    """An error's text for the user: a KeyError's own message (``str`` of a KeyError is
    the repr of its argument, quotes included), any other error's ``str``."""
    if isinstance(error, KeyError) and len(error.args) == 1:
        return str(error.args[0])
    return str(error)


@dataclass(frozen=True)
class DeckIssue:
    """One problem found while reading a deck.

    Attributes
    ----------
    file, line : where the offending text is (1-based line number; 0 for the whole file).
    card : card name (``"GRID"``) or section (``"CASE CONTROL"``); ``""`` if unknown.
    field : NASTRAN field number on its line (2..9), or None for the whole card/line.
    name : the field's name in the Quick Reference Guide (``"X1"``), or None.
    found : the text found, or None.
    expected : what would have been accepted.
    """

    file: str
    line: int
    card: str
    field: int | None
    name: str | None
    found: str | None
    expected: str

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}" if self.line > 0 else self.file
        what = self.card or "deck"
        if self.field is not None:
            what += f" field {self.field}"
            if self.name:
                what += f" ({self.name})"
        elif self.name:
            what += f" {self.name}"
        found = f": found {self.found!r}" if self.found is not None else ""
        return f"{where}: {what}{found}; expected {self.expected}"


class DeckError(FemcalError):
    """A deck could not be read. Holds every issue found (up to a limit), in file order."""

    def __init__(self, issues: Sequence[DeckIssue], truncated: int = 0):
        self.issues = list(issues)
        self.truncated = truncated
        lines = [str(i) for i in self.issues]
        if len(self.issues) == 1 and not truncated and self.issues[0].line == 0:
            super().__init__(lines[0])  # the whole file: one line says it
            return
        head = f"{len(self.issues) + truncated} error(s) in deck"
        if truncated:
            lines.append(f"... and {truncated} more")
        super().__init__(head + ":\n  " + "\n  ".join(lines))


class ModelError(FemcalError):
    """Cards read fine but do not make a consistent model (missing grid, duplicate id, ...).

    Attributes
    ----------
    ids : the NASTRAN ids involved.
    locations : ``"file:line"`` of the cards involved.
    """

    def __init__(self, message: str, ids: Sequence[int] = (), locations: Sequence[str] = ()):
        self.ids = list(ids)
        self.locations = list(locations)
        super().__init__(message)


class SolverError(FemcalError):
    """A numerical solution failed; ``partial`` carries whatever was computed."""

    def __init__(self, message: str, partial: object | None = None):
        self.partial = partial
        super().__init__(message)
