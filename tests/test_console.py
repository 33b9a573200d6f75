"""The console of long commands (femcal.cli.console): phases as lines, details only with
--verbose, counted work as a bar on a terminal and one line when it ends."""

from __future__ import annotations

import io
import re

from femcal.cli.console import Console
from femcal.parallel.progress import Detail, Step


def feed(console: Console) -> None:
    console("cycle 1: Levenberg-Marquardt from every start")
    for k in range(1, 4):
        console(Detail(f"start {k}/3 iteration 1: deviation 10"))
        console(Step(f"start {k}/3 done: deviation 5", task="cycle 1: starts", done=k, total=3))
    console("deviation 10 -> 5")


def test_quiet_console_shows_phases_and_one_line_per_counted_task():
    out = io.StringIO()
    feed(Console(stream=out, bars=False))
    lines = out.getvalue().splitlines()
    assert [re.sub(r"^\[\s*[\d.]+ s\] ", "", x) for x in lines] == [
        "cycle 1: Levenberg-Marquardt from every start",
        re.sub(r"^\[\s*[\d.]+ s\] ", "", lines[1]),
        "deviation 10 -> 5",
    ]
    assert re.fullmatch(r"\[\s*[\d.]+ s\] cycle 1: starts: 3 of 3 in \d+ s", lines[1])
    assert "iteration" not in out.getvalue()


def test_verbose_console_shows_every_line():
    out = io.StringIO()
    feed(Console(stream=out, verbose=True, bars=False))
    text = out.getvalue()
    assert text.count("iteration 1") == 3 and text.count("done: deviation 5") == 3
    assert "cycle 1: starts: 3 of 3" in text


def test_bars_draw_on_a_terminal_and_leave_the_lines():
    out = io.StringIO()
    console = Console(stream=out, bars=True)
    feed(console)
    console.close()
    text = out.getvalue()
    assert "cycle 1: starts: 0/3" in text or "cycle 1: starts: 1/3" in text  # the bar itself
    assert "cycle 1: starts: 3 of 3 in" in text and "deviation 10 -> 5" in text
    assert "iteration" not in text


def test_steps_are_strings_for_callbacks_that_print_them():
    seen: list[str] = []
    s = Step("start 1/2 done", task="t", done=1, total=2)
    seen.append(s)
    seen.append(Detail("x"))
    assert seen == ["start 1/2 done", "x"] and (s.task, s.done, s.total) == ("t", 1, 2)
