"""Pieces of the HTML pages femcal writes (the calibration report, the drive iteration's):
tables, figures with captions and numbers, each escaped."""

from __future__ import annotations

import html


def html_table(rows: list[list[object]], head: list[str]) -> str:
    """A table with a header row; every cell escaped."""
    h = "".join(f"<th>{html.escape(x)}</th>" for x in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                   for r in rows)  # fmt: skip
    return f"<table><tr>{h}</tr>{body}</table>"


def html_number(v: float | None, spec: str) -> str:
    """``v`` formatted by ``spec``, or ``-`` for None."""
    return "-" if v is None else format(v, spec)


def html_figure(title: str, src: str, caption: str) -> str:
    """A figure: its title, the picture ``src`` and a caption."""
    return (f"<figure><h3>{html.escape(title)}</h3><img src='{html.escape(src)}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")
