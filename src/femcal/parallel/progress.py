"""What long work tells whoever watches it: the messages a ``progress`` callback receives
(beside the workers that run it, :mod:`femcal.parallel.executors`).

femcal's long functions take ``progress: Callable[[str], None] | None``. A message is a plain
``str`` (a phase: one line the user sees), or one of the two kinds below, which are ``str``
too, so that a callback that prints whatever it gets keeps working:

* :class:`Detail`: a line worth keeping in a log but not on a quiet console (an iteration of
  one start, a surrogate's centre);
* :class:`Step`: one step of a counted task (start 7 of 24 finished), which a console shows
  as a progress bar with the time left, and a log as its text.

The library never prints; the CLI's console (:mod:`femcal.cli.console`) decides what to show.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["Detail", "Progress", "Step"]


class Detail(str):
    """A detail line: shown on the console only when asked (``--verbose``)."""

    __slots__ = ()


class Step(str):
    """Step ``done`` of ``total`` of the counted task ``task`` (its text: what the step did).

    ``task`` names the task the bar shows (``"cycle 1: starts"``); steps of one task arrive
    with ``done`` rising to ``total``.
    """

    __slots__ = ("done", "task", "total")
    task: str
    done: int
    total: int

    def __new__(cls, text: str, *, task: str, done: int, total: int) -> Step:
        obj = super().__new__(cls, text)
        obj.task, obj.done, obj.total = task, int(done), int(total)
        return obj


#: The type of a progress callback.
Progress = Callable[[str], None]
