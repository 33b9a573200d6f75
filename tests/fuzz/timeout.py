"""What the fuzz harnesses share: an alarm that stops a case that hangs."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager


class Timeout(BaseException):
    """Raised by the alarm in the case it interrupts."""


@contextmanager
def alarm(seconds: float) -> Iterator[list[bool]]:
    """Interrupt the block after ``seconds`` (main thread only; elsewhere no limit); the
    yielded list holds True once the time ran out, whatever caught the interruption."""
    fired = [False]
    if threading.current_thread() is not threading.main_thread():
        yield fired
        return

    def ring(signum: int, frame: object) -> None:
        fired[0] = True
        raise Timeout

    previous = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield fired
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
