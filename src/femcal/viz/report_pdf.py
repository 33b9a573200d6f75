"""The calibration report as a PDF (matplotlib's PdfPages, A4 portrait; a wide figure on a
landscape page), to send on with or
instead of ``report.html``, in the page's order and with its sections: the verdict first
(frequency errors, MAC and misfit before and after, what moved, what to doubt), the
parameters, the held-out validation, the model form tested, each configuration's test,
misfit, suspect channels, paired modes and model form, the runs, one page per figure with
its number, title and caption, and the provenance last (femcal's version, when it was made,
the command, the input files with their sizes and SHA-256 digests, the list of figures).
Tables split over as many pages as they need, their header row repeated.

Every line of text is wrapped by its measured width (the font's own metrics), so nothing runs
past its column or the page's margins; each column is at least as wide as its longest word
(up to a third of the page), so a word is broken between characters only where it is longer
than that (a path, a digest). The document's metadata (Title, Author, Subject, Keywords,
Creator) name femcal and its version. Written atomically."""

from __future__ import annotations

import datetime
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from .figures import pyplot

#: A4 portrait in points, and the margin on every side.
PAGE_W, PAGE_H = 595.28, 841.89
MARGIN = 42.0
#: Font sizes (points): body text, tables, headings, the title, the footer.
BODY, TABLE, HEADING, TITLE, FOOT = 9.0, 7.0, 12.0, 18.0, 6.5
_LEADING = 1.3  # line height over font size
_PAD = 2.5  # a table cell's inner margin (points)


def _no_ligatures() -> dict:
    """Text options that keep every letter its own glyph where matplotlib shapes text
    (3.11 and later: "fi" would become one glyph, and the PDF's text would not read or
    search as written)."""
    from matplotlib.text import Text

    return {"fontfeatures": ["-liga", "-clig"]} if hasattr(Text, "set_fontfeatures") else {}


Table = tuple[str, list[str], list[list[str]]]


@dataclass(frozen=True)
class ConfigurationTexts:
    """One configuration's words as the page has them: its test, its misfit, what the
    suspect-channel table shows (and its header and rows; no rows: none stands out), its
    model-form tables (what each shows, header, rows)."""

    test: str
    misfit: str
    suspects: str
    suspect_head: list[str]
    suspect_rows: list[list[str]]
    model_form: list[Table]


@dataclass(frozen=True)
class ReportTexts:
    """The report's words and tables as the page has them (:mod:`femcal.io.calibration`
    makes them, so that both say the same): the verdict (its header, a table per
    configuration, what moved, what to doubt, the rest of the trust summary), the held-out
    validation (text, header, rows), each configuration's, the runs' tables."""

    verdict_head: list[str]
    verdict_tables: list[tuple[str, list[list[str]]]]
    moved: str
    doubts: list[str]
    rest: list[str]
    holdout: Table | None
    configurations: list[ConfigurationTexts]
    runs: list[Table]


@dataclass(frozen=True)
class PdfReport:
    """The written PDF: its path and what each page holds (``title``, ``parameters``,
    ``modes``, ``figure N``), in order: ``len(pages)`` is its page count."""

    path: Path
    pages: tuple[str, ...]


class _Measure:
    """Text widths in points from the font's metrics (an Agg renderer at 10 x 72 dpi)."""

    def __init__(self) -> None:
        from matplotlib.backends.backend_agg import RendererAgg

        self._r = RendererAgg(10, 10, 720)
        self._props: dict[tuple[float, str, str], object] = {}
        self._cache: dict[tuple[str, float, str, str], float] = {}

    def width(self, s: str, size: float, weight: str = "normal", family: str = "sans-serif"):
        key = (s, size, weight, family)
        w = self._cache.get(key)
        if w is None:
            from matplotlib.font_manager import FontProperties

            prop = self._props.get(key[1:])
            if prop is None:
                prop = self._props[key[1:]] = FontProperties(size=size, weight=weight,
                                                             family=family)  # fmt: skip
            w = self._r.get_text_width_height_descent(s, prop, ismath=False)[0] / 10.0
            self._cache[key] = w
        return w

    def wrap(self, text: str, width: float, size: float, weight: str = "normal",
             family: str = "sans-serif") -> list[str]:  # fmt: skip
        """``text`` broken into lines no wider than ``width`` points (less 2 %, for the
        rounding of glyph positions): at spaces, as many words on a line as fit, and a word
        wider than the line between its characters (its own newlines kept).

        A line's word count is estimated from its words' widths and then checked on the line
        itself, a word more or less at a time (a text's width grows with what is appended to
        it): a line takes a few measurements of its length, not one per word and one per
        character of the word that ends it."""
        width *= 0.98

        def fits(s: str) -> bool:
            return self.width(s, size, weight, family) <= width

        lines: list[str] = []
        for para in str(text).split("\n"):
            words = para.split(" ")
            line, i = "", 0
            while i < len(words):
                # the most words from i that fit after what the line holds: estimated from
                # the words' own widths (each measured once), then checked on the line
                lo, left = 0, len(words) - i
                est = self.width(line, size, weight, family) if line else 0.0
                while lo < left:
                    word = words[i + lo] if not line and not lo else " " + words[i + lo]
                    est += self.width(word, size, weight, family)
                    if est > width:
                        break
                    lo += 1
                lo = max(lo, 1)  # (an estimate: the check decides, from one word on)
                if fits(_joined(line, words[i : i + lo])):
                    while lo < left and fits(_joined(line, words[i : i + lo + 1])):
                        lo += 1
                else:
                    while lo and not fits(_joined(line, words[i : i + lo])):
                        lo -= 1
                if lo:
                    line, i = _joined(line, words[i : i + lo]), i + lo
                    continue
                if line:
                    lines.append(line)
                word, line = words[i], ""
                i += 1
                if fits(word):
                    line = word
                    continue
                for ch in word:  # the word alone, broken where it must be
                    if line and not fits(line + ch):
                        lines.append(line)
                        line = ch
                    else:
                        line += ch
            lines.append(line)
        return lines


def _joined(line: str, words: list[str]) -> str:
    """``words`` appended to ``line`` one by one, each after a space unless the line is
    still empty."""
    for word in words:
        line = f"{line} {word}" if line else word
    return line


class _Document:
    """Pages written one after another, top to bottom, with a cursor (points from the page's
    top) and a footer on each."""

    def __init__(self, pdf, footer: str) -> None:
        self.pdf, self.footer = pdf, footer
        self.measure = _Measure()
        self.options = _no_ligatures()
        self.plt = pyplot()
        self.fig = None
        self.kinds: list[str] = []
        self.y = MARGIN
        self.page_w, self.page_h = PAGE_W, PAGE_H
        self.width = self.page_w - 2 * MARGIN

    # -- pages
    def new_page(self, kind: str, *, landscape: bool = False) -> None:
        """A new page, A4 portrait (``landscape``: turned, for a wide picture)."""
        self.close_page()
        self.page_w, self.page_h = (PAGE_H, PAGE_W) if landscape else (PAGE_W, PAGE_H)
        self.width = self.page_w - 2 * MARGIN
        self.fig = self.plt.figure(figsize=(self.page_w / 72, self.page_h / 72), dpi=72)
        self.kinds.append(kind)
        self.y = MARGIN
        self._text(MARGIN, self.page_h - MARGIN / 2, f"{self.footer}, page {len(self.kinds)}",
                   FOOT, color="0.4", va="baseline")  # fmt: skip

    def close_page(self) -> None:
        if self.fig is not None:
            self.pdf.savefig(self.fig)
            self.plt.close(self.fig)
            self.fig = None

    def room(self) -> float:
        """Points left above the bottom margin."""
        return self.page_h - MARGIN - self.y

    # -- drawing (x, y in points from the top left)
    def _text(self, x: float, y_top: float, s: str, size: float, *, weight: str = "normal",
              family: str = "sans-serif", color: str = "k", ha: str = "left",
              va: str = "top") -> None:  # fmt: skip
        self.fig.text(x / self.page_w, 1 - y_top / self.page_h, s, fontsize=size, weight=weight,
                      family=family, color=color, ha=ha, va=va, parse_math=False,
                      **self.options)  # fmt: skip

    def lines(self, text: str, size: float = BODY, *, weight: str = "normal", indent: float = 0,
              family: str = "sans-serif", kind: str = "", bullet: str = "",
              after: float = 0.4) -> None:  # fmt: skip
        """A paragraph, wrapped to the text width (less ``indent``), continued on a new page
        of ``kind`` when the page is full."""
        step = _LEADING * size
        x = MARGIN + indent
        for k, line in enumerate(self.measure.wrap(text, self.width - indent, size, weight,
                                                   family)):  # fmt: skip
            if self.room() < step:
                self.new_page(kind or self.kinds[-1])
            if bullet and k == 0:
                self._text(x - 9, self.y, bullet, size)
            self._text(x, self.y, line, size, weight=weight, family=family)
            self.y += step
        self.y += after * step

    def heading(self, text: str, size: float = HEADING) -> None:
        if self.room() < 4 * _LEADING * size:  # not alone at the bottom of a page
            self.new_page(self.kinds[-1])
        self.y += 0.3 * size
        self.lines(text, size, weight="bold", after=0.25)

    def table(self, head: Sequence[str], rows: Sequence[Sequence[str]],
              weights: Sequence[float], align: Sequence[str], *, kind: str,
              title: str = "", more: str = "", size: float = TABLE) -> None:  # fmt: skip
        """A table over the text width, columns in proportion to ``weights``, every cell
        wrapped to its column, below the heading ``title``; the header row again at the top
        of each new page, below the heading ``more`` (default: ``title`` continued)."""
        more = more or (f"{title} (continued)" if title else "")
        widths = self._widths(head, rows, weights, size)
        lefts = np.concatenate([[MARGIN], MARGIN + np.cumsum(widths)[:-1]])
        step = 1.2 * size
        wrap = self.measure.wrap

        def cells(row: Sequence[str], weight: str) -> list[list[str]]:
            return [wrap(str(c), w - 2 * _PAD, size, weight) for c, w in zip(row, widths,
                                                                            strict=True)]

        def draw(parts: list[list[str]], weight: str, shade: str | None) -> None:
            height = max(len(p) for p in parts) * step + 2 * _PAD
            if shade is not None:
                self.fig.patches.append(self._rect(MARGIN, self.y, self.width, height, shade))
            for x, w, p, a in zip(lefts, widths, parts, align, strict=True):
                for k, line in enumerate(p):
                    xx = x + _PAD if a == "left" else x + w - _PAD
                    self._text(xx, self.y + _PAD + k * step, line, size, weight=weight,
                               ha="left" if a == "left" else "right")  # fmt: skip
            self.y += height
            self._hline(self.y)

        header = cells(head, "bold")

        def top(continued: bool) -> None:
            if more if continued else title:
                self.heading(more if continued else title)
            self._hline(self.y)
            draw(header, "bold", "0.9")

        top(False)
        for n, row in enumerate(rows):
            parts = cells(row, "normal")
            height = max(len(p) for p in parts) * step + 2 * _PAD
            if self.room() < height:
                self.new_page(kind)
                top(True)
            draw(parts, "normal", "0.97" if n % 2 else None)
        if not rows:
            self.lines("(none)", size)
        self.y += step

    def _widths(self, head: Sequence[str], rows: Sequence[Sequence[str]],
                weights: Sequence[float], size: float) -> list[float]:  # fmt: skip
        """Column widths over the text width in proportion to ``weights``, each at least as
        wide as its longest word in the header (bold) and in the cells (up to a third of
        the width), so that words break only where they are longer than that."""
        def longest(text: str, weight: str) -> float:
            return max((self.measure.width(w, size, weight) for w in str(text).split()),
                       default=0.0)  # fmt: skip

        need = [min(max([longest(h, "bold")] + [longest(r[k], "normal") for r in rows])
                    + 2 * _PAD + 1, self.width / 3) for k, h in enumerate(head)]  # fmt: skip
        w, need_a = np.asarray(weights, float), np.asarray(need)
        fixed = np.zeros(len(w), bool)
        while not fixed.all():  # columns below their need take it, the rest share what is left
            share = (self.width - need_a[fixed].sum()) * w / w[~fixed].sum()
            under = ~fixed & (share < need_a)
            if not under.any():
                break
            fixed |= under
        out = np.where(fixed, need_a, share if not fixed.all() else need_a)
        return list(out * min(1.0, self.width / out.sum()))

    def _box(self, x: float, y_top: float, w: float, h: float
             ) -> tuple[float, float, float, float]:  # fmt: skip
        """A box in points from the page's top left as figure fractions (left, bottom,
        width, height)."""
        return (x / self.page_w, 1 - (y_top + h) / self.page_h, w / self.page_w,
                h / self.page_h)  # fmt: skip

    def _rect(self, x: float, y_top: float, w: float, h: float, color: str):
        from matplotlib.patches import Rectangle

        left, bottom, width, height = self._box(x, y_top, w, h)
        return Rectangle((left, bottom), width, height, transform=self.fig.transFigure,
                         facecolor=color, edgecolor="none", zorder=-1)  # fmt: skip

    def _hline(self, y_top: float) -> None:
        from matplotlib.lines import Line2D

        y = 1 - y_top / self.page_h
        edge = MARGIN / self.page_w
        self.fig.lines.append(Line2D([edge, 1 - edge], [y, y], lw=0.4, color="0.55",
                                     transform=self.fig.transFigure))  # fmt: skip

    def picture(self, png: str | os.PathLike[str], height: float) -> None:
        """A PNG scaled to fit the text width and ``height`` points (its aspect kept),
        centred, below the cursor."""
        import matplotlib.image as mpimg

        img = mpimg.imread(str(png))
        if img.dtype != np.uint8:
            img = np.asarray(img, float)
            if img.ndim == 3 and img.shape[2] == 4:  # composite on white: no alpha in the PDF
                img = img[..., :3] * img[..., 3:] + (1 - img[..., 3:])
            img = np.clip(np.round(255 * img), 0, 255).astype(np.uint8)
        rows, cols = img.shape[:2]
        s = min(self.width / cols, height / rows)
        w, h = cols * s, rows * s
        x = MARGIN + (self.width - w) / 2
        ax = self.fig.add_axes(self._box(x, self.y, w, h))
        ax.imshow(img, interpolation="none", aspect="auto")
        ax.set_axis_off()
        self.y += h + 8


def _size(n: int | None) -> str:
    return "-" if n is None else f"{n:,d}"


def _f(v: float | None, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def _title_pages(doc: _Document, report: dict, head: dict, v: ReportTexts) -> None:
    """The first page: the title, then the verdict (as the page's), then the run in one
    paragraph."""
    doc.new_page("title")
    doc.lines("femcal calibration report", TITLE, weight="bold", after=0.2)
    doc.lines(f"femcal {head['version']}, made {head['made']}", 10.5, after=0.6)
    doc.heading("Verdict")
    for name, rows in v.verdict_tables:
        doc.table(v.verdict_head, rows, [40, 30, 30], ["left", "right", "right"], kind="title",
                  title=name if len(v.verdict_tables) > 1 else "", size=8.0)  # fmt: skip
    doc.lines(v.moved, BODY)
    doc.lines("What to doubt", BODY, weight="bold", after=0.2)
    for line in v.doubts:
        doc.lines(line, BODY, indent=12, bullet="-")
    doc.lines("What holds", BODY, weight="bold", after=0.2)
    for line in v.rest:
        doc.lines(line, BODY, indent=12, bullet="-")
    confs = report["configurations"]
    dev = report["deviation"]
    doc.lines(f"Metric {report['metric']}, "
              f"{'Huber' if report.get('loss') == 'huber' else 'least-squares'} loss; "
              f"{len(confs)} configuration{'s' * (len(confs) > 1)}; deviation "
              f"{dev['before']:.6g} before, {dev['after']:.6g} after; run time "
              f"{report['seconds']:.0f} s.", BODY)  # fmt: skip


def _provenance_pages(doc: _Document, head: dict,
                      figures: Sequence[tuple[int, str, object, str]]) -> None:  # fmt: skip
    """The last pages, as the page's end: what made the report from which files, and the
    list of figures."""
    doc.new_page("provenance")
    doc.lines("Provenance", HEADING, weight="bold", after=0.25)
    doc.lines(f"Made by femcal {head['version']} on {head['made']}"
              + (f" by {head['command']}" if head.get("command") else "")
              + f" in {head['folder']}.", BODY)  # fmt: skip
    rows = [[f["role"], f["path"] or "-", _size(f["bytes"]), f["sha256"] or "not readable"]
            for f in head["inputs"]]  # fmt: skip
    doc.table(["input", "file", "bytes", "SHA-256"], rows, [17, 44, 13, 50],
              ["left", "left", "right", "left"], kind="provenance", title="Inputs",
              size=6.5)  # fmt: skip
    if figures:
        doc.heading("Figures")
        for number, title, _png, _caption in figures:
            doc.lines(f"Figure {number}. {title}", BODY, indent=12, bullet="-", after=0.1)


def _number(text: str) -> bool:
    try:
        float(str(text).replace("%", "").strip() or "x")
    except ValueError:
        return str(text).strip() in ("-", "")
    return True


def _aligns(rows: Sequence[Sequence[str]], n: int) -> list[str]:
    """Numbers to the right, words to the left: a column of numbers (or blanks) is aligned
    right."""
    return ["right" if rows and all(_number(r[k]) for r in rows) else "left" for k in range(n)]


def _sections(doc: _Document, report: dict, texts: ReportTexts) -> None:
    """The held-out validation, the model-form test, each configuration's test, misfit,
    suspect channels and model form, and the runs: every table of the page."""

    def tables(parts, kind: str) -> None:
        for text, head, rows in parts:
            doc.lines(text, BODY)
            doc.table(head, rows, [1] * len(head), _aligns(rows, len(head)), kind=kind)

    if texts.holdout is not None:
        doc.new_page("held-out validation")
        doc.lines("Validation on held-out data", HEADING, weight="bold", after=0.25)
        text, head, rows = texts.holdout
        doc.lines(text, BODY)
        doc.table(head, rows, [2, 1, 1.3, 1.6, 1], ["left"] + ["right"] * 4,
                  kind="held-out validation")  # fmt: skip
    a = report.get("augmented")
    if a is not None:
        doc.heading("Model form tested: the calibration with the missing element added")
        doc.lines(f"{a['element']} in configuration {a['configuration']} ({'; '.join(a['cards'])}"
                  f", in {a['deck']}), parameter {a['parameter']['name']} calibrated to "
                  f"{a['parameter']['calibrated']:.4g}; deviation after calibration "
                  f"{a['deviation_after']:.6g} against {report['deviation']['after']:.6g} "
                  f"without; {a['reason']}. Its own report: {a['report']}.", BODY)
        first = {p["name"]: p for p in report["parameters"]}
        rows = [[name, _f(first[name]["calibrated"], ".6g") if name in first
                 else "(not in the model)", _f(value, ".6g")]
                for name, value in a["parameters"].items()]  # fmt: skip
        doc.table(["parameter", "calibrated without it", "calibrated with it"], rows,
                  [1, 1, 1], ["left", "right", "right"], kind="model form tested")  # fmt: skip
    confs = report["configurations"]
    for c, t in zip(confs, texts.configurations, strict=True):
        kind = f"configuration {c['name']}"
        doc.new_page(kind)
        doc.lines(f"Configuration {c['name']}" if len(confs) > 1 else "Test", HEADING,
                  weight="bold", after=0.25)  # fmt: skip
        doc.lines(t.test, BODY)
        doc.lines(t.misfit, BODY)
        if t.suspect_rows:
            doc.heading("Suspect channels")
            doc.lines(t.suspects, BODY)
            doc.table(t.suspect_head, t.suspect_rows, [12, 10, 8, 8, 8, 36, 30],
                      ["left", "left", "right", "right", "right", "left", "left"],
                      kind=kind)  # fmt: skip
        else:
            doc.lines(t.suspects, BODY)
        _mode_table(doc, c, len(confs) > 1)
        form = c.get("model_form")
        if form is not None:
            doc.heading("Model form")
            for line in form["suggestions"]:
                doc.lines(line, BODY, indent=12, bullet="-")
            tables(t.model_form, kind)
    doc.new_page("runs")
    doc.lines("Runs", HEADING, weight="bold", after=0.25)
    tables(texts.runs, "runs")


def _status(p: dict) -> str:
    s = "held" if p["held"] else ("identifiable" if p["identifiable"] else "weakly informed")
    return s + (" (at a bound!)" if p["at_bound"] else "")


def _parameter_pages(doc: _Document, report: dict) -> None:
    doc.new_page("parameters")
    params = report["parameters"]
    head = ["name", "description", "card, id, field", "nominal", "calibrated", "change %",
            "prior std %", "posterior std %", "status"]  # fmt: skip
    weights = [26, 96, 46, 42, 44, 36, 30, 42, 58]
    truth = any("true" in p for p in params)
    rows = []
    for p in params:
        row = [p["name"], p["description"] or "", f"{p['card']} {p['id']} {p['field']}",
               _f(p["nominal"], ".6g"), _f(p["calibrated"], ".6g"), f"{100 * p['p']:+.2f}",
               f"{100 * p['prior_std_p']:.2f}",
               "-" if p["held"] else f"{100 * p['posterior_std_p']:.2f}", _status(p)]
        if truth:
            row += [_f(p.get("true"), ".6g"), _f(p.get("error_pct"), "+.2f")]
        rows.append(row)
    if truth:
        head += ["true", "error %"]
        weights += [42, 32]
    align = ["left", "left", "left", *["right"] * 5, "left", "right", "right"][: len(head)]
    post = report["posterior"]
    doc.lines("Parameters", HEADING, weight="bold", after=0.25)
    doc.lines("Change: from the nominal value. Prior and posterior standard deviations in % of "
              "the nominal value. Identifiable: the posterior standard deviation below "
              f"{100 * post['identifiable_below']:g} % of the prior's; held: the test cannot "
              f"narrow the prior by more than {100 * (1 - post['hold_ratio']):g} %, so the "
              "parameter keeps its nominal value"
              + ("; true: the synthetic test's hidden value." if truth else "."), 7.5)
    doc.table(head, rows, weights, align, kind="parameters", more="Parameters (continued)")
    for p in params:
        doc.lines(f"{p['name']}: {p['reason']}", 7.5, indent=12, bullet="-", after=0.1)


def _mode_table(doc: _Document, c: dict, several: bool) -> None:
    """A configuration's paired-modes table."""
    head = ["test mode", "test Hz", "FE mode before", "FE before Hz", "FE mode after",
            "FE after Hz", "error before %", "error after %", "MAC before", "MAC after"]
    title = "Paired modes" + (f": configuration {c['name']}" if several else "")
    if not c["modes"]:
        doc.heading(title)
        doc.lines("No identified test modes (the raw FRFs were compared).", BODY)
        return
    rows = [[str(m["test_mode"]), f"{m['test_hz']:.3f}", _f(m["fe_before_mode"], "d"),
             _f(m["fe_before_hz"], ".3f"), _f(m["fe_after_mode"], "d"),
             _f(m["fe_after_hz"], ".3f"), _f(m["frequency_error_before_pct"], "+.2f"),
             _f(m["frequency_error_after_pct"], "+.2f"), _f(m["mac_before"], ".4f"),
             _f(m["mac_after"], ".4f")] for m in c["modes"]]  # fmt: skip
    doc.table(head, rows, [1] * len(head), ["right"] * len(head), kind=doc.kinds[-1],
              title=title)  # fmt: skip
    doc.lines("Frequency error: (test - FE) / FE. Each test mode is paired with the FE mode of "
              "the highest MAC within a frequency ratio, each FE mode once "
              "(femcal.correlate).", 7.5)


def _landscape(doc: _Document, png: str | os.PathLike[str], caption: str) -> bool:
    """Whether a picture is drawn at least a fifth larger on a landscape page than on a
    portrait one (a wide figure: rows of panels, a long channel axis)."""
    import matplotlib.image as mpimg

    rows, cols = mpimg.imread(str(png)).shape[:2]

    def scale(width: float, height: float) -> float:
        lines = len(doc.measure.wrap(caption, width, BODY)) + 3  # caption and titles
        return min(width / cols, (height - 2 * MARGIN - lines * _LEADING * HEADING) / rows)

    text_w = PAGE_W - 2 * MARGIN
    return scale(PAGE_H - 2 * MARGIN, PAGE_W) > 1.2 * scale(text_w, PAGE_H)


def _figure_page(doc: _Document, number: int, title: str, png: str | os.PathLike[str],
                 caption: str, heading: str = "") -> None:  # fmt: skip
    doc.new_page(f"figure {number}", landscape=_landscape(doc, png, caption))
    if heading:
        doc.lines(heading, HEADING, weight="bold", after=0.25)
    doc.lines(f"Figure {number}. {title}", HEADING, weight="bold", after=0.5)
    cap = doc.measure.wrap(f"Figure {number}. {caption}", doc.width, BODY)
    space = doc.room() - len(cap) * _LEADING * BODY - 12
    doc.picture(png, max(space, 120.0))
    doc.lines(f"Figure {number}. {caption}", BODY)


def write_report_pdf(path: str | os.PathLike[str], report: dict, head: dict,
                     figures: Sequence[tuple[int, str, str | os.PathLike[str], str]],
                     *, title: str = "femcal calibration report",
                     headings: dict[int, str] | None = None,
                     texts: ReportTexts) -> PdfReport:  # fmt: skip
    """Write the calibration report ``report`` (``report.json``'s content,
    :func:`femcal.io.calibration.report_dict`) as an A4 PDF: the title page(s) with the
    header ``head`` (:func:`femcal.io.html.provenance`: version, date, command, the input
    files) and the summary, the parameter table, the paired-modes tables, then one page per
    figure (number, title, PNG file, caption; ``headings``: a heading above figure N, the
    page's group title). Written atomically; returns the path and what each page holds."""
    from matplotlib import rc_context
    from matplotlib.backends.backend_pdf import PdfPages

    path = Path(path)
    made = datetime.datetime.fromisoformat(head["made"])
    who = f"femcal {head['version']}"
    confs = report.get("configurations", [])
    meta = {"Title": title, "Author": who, "Creator": who,
            "Subject": f"{title}, made {head['made']} by {who}: "
                       + "; ".join(f"deck {c['deck']}, test {c['test']}" for c in confs),
            "Keywords": "femcal, calibration, finite elements, modal test",
            "CreationDate": made}  # fmt: skip
    kinds: list[str] = []

    def write(tmp: str) -> None:
        with rc_context({"pdf.fonttype": 3, "pdf.compression": 6}), \
                PdfPages(tmp, metadata=meta) as pdf:  # fmt: skip
            doc = _Document(pdf, f"{who} - {title}, made {head['made']}")
            try:
                _title_pages(doc, report, head, texts)
                _parameter_pages(doc, report)
                _sections(doc, report, texts)
                for number, caption_title, png, caption in figures:
                    _figure_page(doc, number, caption_title, png, caption,
                                 (headings or {}).get(number, ""))
                _provenance_pages(doc, head, figures)
                doc.close_page()
            finally:
                if doc.fig is not None:
                    doc.plt.close(doc.fig)
            kinds[:] = doc.kinds

    write_atomic(path, write)
    return PdfReport(path, tuple(kinds))
