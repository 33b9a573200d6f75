"""The console of long commands: one timestamped line per phase, a progress bar with the time
left for counted work, the details only with ``--verbose``.

A :class:`Console` is the ``progress`` callback the CLI hands to the library
(:mod:`femcal.parallel.progress`):

* a plain message is a line ``[   12.3 s] text`` on standard error;
* a :class:`~femcal.parallel.progress.Detail` is such a line with ``--verbose``, nothing otherwise;
* a :class:`~femcal.parallel.progress.Step` moves its task's bar (tqdm: done / total, time
  spent and left) on a terminal, none where standard error is not one (a log file, CI); the
  task's last step ends it with one line (``cycle 1: starts: 24 of 24 in 31 s``; none for a
  task of one step). With ``--verbose`` each step's own text is printed as well.

Lines printed while a bar is open go through tqdm, above the bar, so the two never mix.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from ..parallel.progress import Detail, Step


class Console:
    """Progress callback for a command; ``close()`` ends any bar left open."""

    def __init__(self, *, verbose: bool = False, stream: TextIO | None = None,
                 bars: bool | None = None, t0: float | None = None) -> None:  # fmt: skip
        """``bars``: draw bars (default: when the stream is a terminal); ``t0``: the
        ``time.perf_counter()`` the timestamps count from (default: now)."""
        self.verbose = verbose
        self.stream = stream if stream is not None else sys.stderr
        self.t0 = time.perf_counter() if t0 is None else t0
        self.bars = _is_terminal(self.stream) if bars is None else bars
        self._bar = None
        self._task: str | None = None
        self._task_t0 = 0.0

    def __call__(self, msg: str) -> None:
        if isinstance(msg, Step):
            self._step(msg)
        elif isinstance(msg, Detail):
            if self.verbose:
                self.line(str(msg))
        else:
            self.line(str(msg))

    def line(self, text: str) -> None:
        """One timestamped line, above the bar if one is open."""
        out = f"[{time.perf_counter() - self.t0:7.1f} s] {text}"
        if self._bar is not None:
            self._bar.write(out, file=self.stream)
        else:
            print(out, file=self.stream, flush=True)

    def _step(self, s: Step) -> None:
        if s.task != self._task:
            self.close()
            self._task, self._task_t0 = s.task, time.perf_counter()
            if self.bars:
                from tqdm import tqdm

                self._bar = tqdm(total=s.total, desc=s.task, file=self.stream, leave=False,
                                 unit="", dynamic_ncols=True,
                                 bar_format="{desc}: {n}/{total} |{bar}| {elapsed}<{remaining}")
        if self.verbose:
            self.line(str(s))
        if self._bar is not None:
            self._bar.n = min(s.done, s.total)
            self._bar.refresh()
        if s.done >= s.total:
            took = time.perf_counter() - self._task_t0
            task = self._task
            self.close()
            if s.total > 1:  # a task of one step is the phase line already said
                self.line(f"{task}: {s.total} of {s.total} in {took:.0f} s")

    def close(self) -> None:
        """End the open bar (if any)."""
        if self._bar is not None:
            self._bar.close()
        self._bar, self._task = None, None


def _is_terminal(stream: TextIO) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
