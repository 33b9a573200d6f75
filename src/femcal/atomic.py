"""Atomic file writing: a result file appears whole or not at all, and a run's set of files
in a folder is written by one run at a time."""

from __future__ import annotations

import errno
import fcntl
import os
import re
import secrets
import socket
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path


def _host() -> str:
    """This machine's name as it goes into a file name."""
    return re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname()) or "host"


def _temporary_prefix(path: Path, pid: int) -> str:
    return f".{path.name}.{_host()}.{pid}."


def remove_stale_temporaries(path: Path) -> list[Path]:
    """Remove the temporary files that writers of ``path`` on this machine killed before they
    finished (SIGKILL, power loss) left beside it: names of exactly the form the writer gives
    them (``.NAME.HOST.PID.XXXXXXXX.SUFFIX``), with this machine's name and the id of a
    process that no longer runs. Another machine's writer on a shared folder, or another
    target's temporaries, are left alone. Returns the files removed."""
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.{re.escape(_host())}\.(\d+)\."
                         rf"[a-z0-9_]{{8}}{re.escape(path.suffix)}$")  # fmt: skip
    removed = []
    try:
        candidates = list(path.parent.iterdir())
    except OSError:
        return removed
    for p in candidates:
        m = pattern.match(p.name)
        if m is None or _alive(int(m.group(1))):
            continue
        try:
            p.unlink()
            removed.append(p)
        except OSError:
            pass
    return removed


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # another user's process, or not a pid we can ask about: leave it
    return True


#: The letters of a temporary file's random part: those :func:`remove_stale_temporaries`'
#: pattern takes (``[a-z0-9_]``).
_NAME_LETTERS = "abcdefghijklmnopqrstuvwxyz0123456789_"


def write_atomic(path: str | os.PathLike[str], write: Callable[[str], None]) -> Path:
    """Call ``write(tmp)`` to write a temporary file beside ``path`` (same suffix, so writers
    that go by the suffix behave), give it the usual permissions and rename it to ``path``.
    On any error the temporary file is removed and ``path`` is left as it was. The temporary
    file's name holds the writer's process id, so that the next writer of ``path`` removes
    what a killed one left."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)
    tmp = ""
    try:
        for _ in range(100):
            # the name is held before the file exists, so that an interruption (Ctrl-C) at
            # any point after the file is made finds it to remove (tempfile.mkstemp makes
            # the file before it returns the name: an interruption between would leave it)
            letters = "".join(secrets.choice(_NAME_LETTERS) for _ in range(8))
            tmp = str(path.parent / f"{_temporary_prefix(path, os.getpid())}{letters}"
                                    f"{path.suffix}")  # fmt: skip
            try:
                os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
                break
            except FileExistsError:
                tmp = ""  # another thread's of this process: not this writer's to remove
        else:
            raise FileExistsError(errno.EEXIST, "no free temporary name beside it", str(path))
        write(tmp)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # (created 0o600 above)
        os.replace(tmp, path)
    except OSError as e:
        if tmp:
            Path(tmp).unlink(missing_ok=True)
        named = Path(str(e.filename)).name if e.filename is not None else ""
        if named.startswith(_temporary_prefix(path, os.getpid())):
            # the temporary file is femcal's business: the error names the file asked for
            raise type(e)(e.errno, e.strerror, str(path)) from None
        raise
    except BaseException:
        if tmp:
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


@contextmanager
def folder_lock(folder: str | os.PathLike[str]) -> Iterator[Path]:
    """Hold an exclusive lock on ``folder`` (made if missing) while a run writes its set of
    files there: two runs writing into one folder at once then take turns, and the folder
    ends with one run's consistent set (the later one's), never a mix. The lock is
    ``flock`` on the folder itself (no lock file is left); it is released when the block
    ends, however it ends, and by the system if the process dies."""
    path = Path(folder)
    path.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield path
    finally:
        os.close(fd)  # closing the descriptor releases the lock
