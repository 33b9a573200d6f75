"""Pieces of the HTML pages femcal writes (the calibration report, the drive iteration's):
tables, numbered figures with captions and their pictures embedded as data URIs, the header
that says what made the page from which files, each escaped. A page built from them is one
file that can be sent on: it refers to nothing beside it and to nothing on the web."""

from __future__ import annotations

import base64
import datetime
import hashlib
import html
import os
import re
import shlex
import sys
from pathlib import Path


def html_table(rows: list[list[object]], head: list[str]) -> str:
    """A table with a header row; every cell escaped."""
    h = "".join(f"<th>{html.escape(x)}</th>" for x in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                   for r in rows)  # fmt: skip
    return f"<table><tr>{h}</tr>{body}</table>"


def html_number(v: float | None, spec: str) -> str:
    """``v`` formatted by ``spec``, or ``-`` for None."""
    return "-" if v is None else format(v, spec)


def data_uri(picture: str | os.PathLike[str] | bytes, mime: str = "image/png") -> str:
    """A picture (a file's path, or its bytes) as a ``data:`` URI, to embed in a page."""
    raw = picture if isinstance(picture, bytes) else Path(picture).read_bytes()
    return f"data:{mime};base64," + base64.b64encode(raw).decode("ascii")


def html_figure(title: str, src: str, caption: str, *, number: int | None = None,
                css_class: str = "") -> str:  # fmt: skip
    """A figure: its title, the picture ``src`` (a ``data:`` URI keeps the page whole) and a
    caption; with ``number``, titled and captioned ``Figure N`` and anchored ``#figure-N``."""
    cls = f" class='{html.escape(css_class)}'" if css_class else ""
    if number is None:
        return (f"<figure{cls}><h3>{html.escape(title)}</h3><img src='{html.escape(src)}' "
                f"alt='{html.escape(title)}'><figcaption>{html.escape(caption)}</figcaption>"
                "</figure>")  # fmt: skip
    return (f"<figure id='figure-{number}'{cls}><h3>Figure {number}. {html.escape(title)}</h3>"
            f"<img src='{html.escape(src)}' alt='Figure {number}: {html.escape(title)}'>"
            f"<figcaption><b>Figure {number}.</b> {html.escape(caption)}</figcaption></figure>")


def embedded_figure(title: str, picture: str | os.PathLike[str], caption: str, *,
                    number: int | None = None, css_class: str = "") -> str:  # fmt: skip
    """:func:`html_figure` with the PNG file ``picture`` embedded; a picture that is not there
    is said so in the page (nothing refers to a file)."""
    try:
        src = data_uri(picture)
    except OSError:
        return (f"<figure><h3>{'' if number is None else f'Figure {number}. '}"
                f"{html.escape(title)}</h3><p>(picture {html.escape(Path(picture).name)} was "
                f"not drawn)</p><figcaption>{html.escape(caption)}</figcaption></figure>")
    return html_figure(title, src, caption, number=number, css_class=css_class)


def file_facts(role: str, path: str | os.PathLike[str] | None) -> dict:
    """What a page's header says of an input file: its role, path, size in bytes and
    SHA-256 digest (None for both when it cannot be read)."""
    size = digest = None
    if path is not None:
        h = hashlib.sha256()
        try:
            with open(path, "rb") as fh:
                for block in iter(lambda: fh.read(1 << 20), b""):
                    h.update(block)
            size, digest = os.path.getsize(path), h.hexdigest()
        except OSError:
            pass
    return {"role": role, "path": None if path is None else str(path), "bytes": size,
            "sha256": digest}  # fmt: skip


def command_line(argv: list[str] | None = None) -> str | None:
    """The femcal command line this process runs (``femcal calibrate cal.toml --out r``),
    or None when femcal was not started from its command line (a script, the tests)."""
    argv = sys.argv if argv is None else argv
    if not argv:
        return None
    first = Path(argv[0])
    if first.name == "femcal" or (first.name == "__main__.py" and first.parent.name == "femcal"):
        return shlex.join(["femcal", *argv[1:]])
    return None


def provenance(inputs: list[dict], *, command: str | None = None,
               made: datetime.datetime | None = None) -> dict:  # fmt: skip
    """A page's header: femcal's version, when it was made (local time with its offset), the
    command line (:func:`command_line` when not given), the working folder and the input
    files (:func:`file_facts`)."""
    from .. import __version__

    made = made or datetime.datetime.now().astimezone()
    return {"version": __version__, "made": made.isoformat(timespec="seconds"),
            "command": command if command is not None else command_line(),
            "folder": os.getcwd(), "inputs": inputs}  # fmt: skip


def html_header(head: dict) -> str:
    """The header block of :func:`provenance`: version, date, command, the inputs with their
    sizes and digests."""
    esc = html.escape
    rows = "".join(
        f"<tr><td>{esc(f['role'])}</td><td class='path'>{esc(f['path'] or '-')}</td>"
        f"<td>{'-' if f['bytes'] is None else format(f['bytes'], ',d')}</td>"
        f"<td class='digest'>{esc(f['sha256'] or 'not readable')}</td></tr>"
        for f in head["inputs"])  # fmt: skip
    command = head.get("command")
    return (f"<div class='provenance'><p>Made by femcal {esc(head['version'])} on "
            f"{esc(head['made'])}"
            + (f" by <code>{esc(command)}</code>" if command else "")
            + f" in <code>{esc(head['folder'])}</code>.</p>"
            + ("<table class='inputs'><tr><th>input</th><th>file</th><th>bytes</th>"
               f"<th>SHA-256</th></tr>{rows}</table>" if rows else "")
            + "</div>")  # fmt: skip


#: The style of the header block and of numbered figures, for a page's ``<style>``.
HEADER_STYLE = (".provenance{background:#f7f7f7;border:1px solid #ddd;padding:0.3em 1em;"
                "font-size:0.9em}.provenance table{margin:0.5em 0}"
                ".provenance td,.provenance th{text-align:left}td.digest{font-family:monospace;"
                "font-size:0.85em}td.path{word-break:break-all}")  # fmt: skip

#: The style of a report page: readable at 1024 px without sideways scrolling (wide tables
#: scroll inside their own box, long words break), the verdict block set apart, then
#: :data:`HEADER_STYLE`.
PAGE_STYLE = ("body{font-family:sans-serif;margin:1.5em;max-width:1400px;overflow-wrap:anywhere}"
              "table{border-collapse:collapse;margin:1em 0;display:block;max-width:100%;"
              "overflow-x:auto;font-size:0.9em}"
              "td,th{border:1px solid #bbb;padding:2px 5px;text-align:right;"
              "overflow-wrap:normal}th{background:#eee}"
              "img{max-width:100%;height:auto;display:block;margin:0.5em 0}"
              "figure{margin:1.5em 0}figcaption{color:#333;max-width:1100px;font-size:0.95em}"
              ".verdict{background:#f3f6fa;border:2px solid #4a6d94;padding:0.3em 1.2em;"
              "margin:0 0 1.5em 0}.verdict h2{margin:0.4em 0}.verdict td{background:#fff}"
              "ul.doubt li{margin:0.3em 0}ul.summary{padding-left:1.5em}"
              ".verdict p.sentence{font-size:1.1em;font-weight:600}"
              ".matrix table{font-size:0.78em}.matrix th{font-weight:normal}"
              "p.nav{font-size:0.95em;color:#333}"
              + HEADER_STYLE)  # fmt: skip

_ATTR = re.compile(r"""\b(?:src|href|action|poster|data|srcset)\s*=\s*(?:"([^"]*)"|'([^']*)'|"""
                   r"""([^\s>]+))""", re.I)  # fmt: skip
_URL = re.compile(r"""url\(\s*['"]?([^'")]*)""", re.I)
_DATA = re.compile(r"data:[\w.+/-]+;base64,[A-Za-z0-9+/=]*")


def outside_references(page: str) -> list[str]:
    """What in a page would load something from outside its file: every ``src``, ``href``
    (and the like) or CSS ``url()`` that is not a ``data:`` URI or a ``#`` anchor, and every
    web address in its text (the embedded data left out). A page that can be sent on has
    none."""
    bare = _DATA.sub("data:", page)
    found = [v for m in _ATTR.finditer(bare) for v in m.groups() if v is not None
             and not (v.startswith("data:") or v.startswith("#"))]  # fmt: skip
    found += [m.group(1) for m in _URL.finditer(bare)
              if not (m.group(1).startswith("data:") or m.group(1).startswith("#"))]  # fmt: skip
    found += re.findall(r"(?:https?|ftp|file)://[^\s'\"<>]*", bare, re.I)
    return found
