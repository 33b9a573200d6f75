"""Atomic file writing: a result file appears whole or not at all."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path


def write_atomic(path: str | os.PathLike[str], write: Callable[[str], None]) -> Path:
    """Call ``write(tmp)`` to write a temporary file beside ``path`` (same suffix, so writers
    that go by the suffix behave), give it the usual permissions and rename it to ``path``.
    On any error the temporary file is removed and ``path`` is left as it was."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # mkstemp makes it private
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_lines(path: str | os.PathLike[str], lines: Iterable[str], *,
                encoding: str = "utf-8") -> Path:  # fmt: skip
    """Write text ``lines`` (each ended by a newline) to ``path`` atomically."""

    def dump(tmp: str) -> None:
        with open(tmp, "w", encoding=encoding, newline="\n") as fh:
            for line in lines:
                fh.write(line)
                fh.write("\n")

    return write_atomic(path, dump)
