"""Reports a lab can send on (issue 27): the calibration's ``report.html`` is one file (every
picture embedded as a PNG data URI, nothing referred to beside it or on the web, a header
naming femcal's version, the date, the command and the inputs with their sizes and SHA-256
digests, numbered figures with captions) and ``report.pdf`` holds the same (title page,
tables, one page per figure, on A4, no text past the page's margins); the rig pages embed
their pictures too."""

from __future__ import annotations

import base64
import datetime
import hashlib
import os
import re
import signal
import subprocess
import tempfile
import zlib

import numpy as np
import pytest

from femcal import __version__
from femcal.calibrate.config import read_config
from femcal.calibrate.parameters import with_values
from femcal.io.html import command_line, outside_references
from femcal.jobs.calibration import run
from femcal.viz.webview import find_browser, read_webview

from .browser import assert_verdict_first_at_1024, needs_browser
from .calib_decks import INS, OUTS, TRUE_P, plate_deck, write_modal_test, write_plate

PNG = b"\x89PNG\r\n\x1a\n"
#: One start, one cycle, no hold-out: the files are what is tested, not the calibration.
CONFIG = """
[model]
deck = "main.bdf"
parameters = "p.toml"

[test]
frf = "test.npz"
sensors = "sensors.csv"

[test.identify]
band = [10.0, 560.0]
splits = [100.0, 260.0, 450.0]

[calibration]
band = [10.0, 350.0]
zeta0 = "median"
reduction_modes = 40
starts = 1
workers = 1
seed = 1
max_cycles = 1
noise_sigma = 0.01
identifiable_ratio = 0.1
holdout = "none"
"""
COMMAND = "femcal calibrate cal.toml --out out"


def _split_deck() -> dict[str, str]:
    """The plate deck with its properties in an INCLUDE file."""
    lines = plate_deck().splitlines()
    cards = ("MAT1", "PSHELL", "PBAR", "PROD", "PBUSH", "PELAS")
    rest = [x for x in lines if not x.startswith(cards)]
    k = rest.index("BEGIN BULK") + 1
    return {"main.bdf": "\n".join([*rest[:k], "INCLUDE 'props.bdf'", *rest[k:]]) + "\n",
            "props.bdf": "\n".join(x for x in lines if x.startswith(cards)) + "\n"}  # fmt: skip


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """A small identified calibration of the plate (its deck split by an INCLUDE, sensors
    named) and its report written: (folder, result, page path)."""
    from femcal.io.calibration import write_report

    d = tmp_path_factory.mktemp("report")
    model, params = write_plate(d)
    for name, text in _split_deck().items():
        (d / name).write_text(text)
    truth = with_values(model, params, [p.value(x) for p, x in zip(params, TRUE_P, strict=True)])
    outs = write_modal_test(d / "test.npz", truth, OUTS, INS)
    grids = sorted({c.grid for c in outs})
    (d / "sensors.csv").write_text("label,grid,directions\n"
                                   + "".join(f"S{g:02d},{g},123\n" for g in grids))  # fmt: skip
    (d / "cal.toml").write_text(CONFIG)
    result = run(read_config(d / "cal.toml"), d / "out")
    page = write_report(result, d / "out", command=COMMAND)
    return d, result, page


def _images(text: str) -> list[str]:
    return re.findall(r"<img\b[^>]*\bsrc='([^']*)'", text)


def test_the_page_refers_to_nothing_outside_itself(report):
    _, _, page = report
    text = page.read_text()
    assert outside_references(text) == []
    # every src or href at all is a data URI or an anchor in the page
    targets = re.findall(r"""\b(?:src|href)\s*=\s*['"]([^'"]*)""", text)
    assert targets and all(t.startswith(("data:", "#")) for t in targets)
    for anchor in (t for t in targets if t.startswith("#")):
        assert f"id='{anchor[1:]}'" in text, anchor
    assert "http://" not in text and "https://" not in text
    # the pictures folder can go: nothing in the page needs it
    assert "pictures/" not in text and ".png" not in text


def test_every_figure_is_numbered_captioned_and_an_embedded_png(report):
    d, result, page = report
    text = page.read_text()
    images = _images(text)
    numbers = [int(n) for n in re.findall(r"<figure id='figure-(\d+)'", text)]
    assert numbers == list(range(1, len(numbers) + 1)) and len(images) == len(numbers)
    assert len(numbers) >= 6  # parameters, history, FRFs, model form, MAC, shapes, ...
    for src in images:
        head, _, data = src.partition(",")
        assert head == "data:image/png;base64"
        assert base64.b64decode(data)[:8] == PNG
    assert len(re.findall(r"<figcaption><b>Figure \d+\.</b> \S", text)) == len(numbers)
    # the calibrated paired modes are rendered and embedded as figures too
    paired = sorted({m.fe_after for m in result.cases[0].modes if m.fe_after is not None})
    assert paired and len(re.findall(r"<figure id='figure-\d+' class='mode'>", text)) == len(
        paired)
    # the separate PNG files stay, for other tools
    for name in ("parameters.png", "history.png", "frf.png", "mac.png", "vectors.png"):
        assert (d / "out" / "pictures" / name).read_bytes()[:8] == PNG
    assert len(list((d / "out" / "pictures" / "modes").glob("mode_*.png"))) == len(paired)


def test_the_header_names_the_version_date_command_and_inputs(report):
    d, _, page = report
    text = page.read_text()
    assert f"femcal {__version__}" in text
    assert datetime.date.today().isoformat() in text
    assert COMMAND in text
    for name in ("cal.toml", "main.bdf", "props.bdf", "p.toml", "test.npz", "sensors.csv"):
        raw = (d / name).read_bytes()
        row = re.search(rf"<tr><td>[^<]*</td><td class='path'>[^<]*{re.escape(name)}</td>"
                        r"<td>([\d,]+)</td><td class='digest'>([0-9a-f]{64})</td>", text)
        assert row, name
        assert int(row.group(1).replace(",", "")) == len(raw)
        assert row.group(2) == hashlib.sha256(raw).hexdigest()
    # sensor names label the figures' captions and the FRF panels' titles (in the PNG)
    assert "sensor" in text


def test_several_configurations_each_get_their_inputs_and_figures(report, tmp_path):
    """The calibration as if of two configurations (the same one twice under two names):
    each one's files in the header under its name, its figures titled by it and numbered on
    from the whole calibration's; the PDF has a paired-modes table for each."""
    from dataclasses import replace

    from femcal.io.calibration import write_report

    d, result, _ = report
    conf, case = result.config.configurations[0], result.cases[0]
    other = tmp_path / "other.npz"
    other.write_bytes((d / "test.npz").read_bytes() + b"\0")
    two = replace(result, config=replace(result.config, configurations=(
        conf, replace(conf, name="again", test_frf=other))),
        cases=(case, replace(case, name="again")))  # fmt: skip
    text = write_report(two, tmp_path / "out").read_text()
    assert outside_references(text) == []
    for name in (conf.name, "again"):
        assert f"<td>{name}: test FRFs</td>" in text
        assert f"FRFs: test, FE before and after ({name})" in text
    # each file once, with each of its roles
    assert text.count("main.bdf</td>") == 1
    assert f"<td>{conf.name}: deck, again: deck</td>" in text
    titles = re.findall(r"<h3>Figure (\d+)\. ([^<]*)</h3>", text)
    assert [int(n) for n, _ in titles] == list(range(1, len(titles) + 1))
    assert [t for _, t in titles][:2] == ["Parameters: prior, calibrated value and posterior",
                                          "Deviation history"]  # fmt: skip
    assert len(_images(text)) == len(titles)
    raw = (tmp_path / "out" / "report.pdf").read_bytes()
    # the verdict, the parameters, each configuration, the runs, the figures, the provenance
    assert len(re.findall(rb"/Type\s*/Page\b", raw)) >= 6 + len(titles)
    pdf = _pdf_text(raw)
    assert f"Paired modes: configuration {conf.name}" in pdf
    assert "Paired modes: configuration again" in pdf


def test_the_command_line_is_femcals_own_or_unknown():
    assert command_line(["/x/.venv/bin/femcal", "calibrate", "a b.toml", "--out", "r"]) == \
        "femcal calibrate 'a b.toml' --out r"  # fmt: skip
    assert command_line(["/x/src/femcal/__main__.py", "rig", "iterate"]) == "femcal rig iterate"
    assert command_line(["/usr/bin/pytest", "-q"]) is None


def _pdf_text(raw: bytes) -> str:
    """The text of a PDF's content streams as matplotlib writes them (Type 3 fonts: each
    string's characters as they are), joined without the kerning between them."""
    out = []
    view = memoryview(raw)
    for m in re.finditer(rb"\bstream\r?\n", raw):
        try:  # to the end of the compressed data (its last byte may be a CR or LF)
            stream = zlib.decompressobj().decompress(view[m.end():])
        except zlib.error:
            continue
        if re.search(rb"[\x00-\x08]", stream[:4096]) or b"T" not in stream:  # pixels
            continue
        for block in re.findall(rb"\[(.*?)\]\s*TJ|\((.*?)\)\s*Tj", stream, re.S):
            parts = re.findall(rb"\(((?:\\.|[^\\)])*)\)", block[0]) if block[0] else [block[1]]
            out.append(b"".join(parts).replace(b"\\(", b"(").replace(b"\\)", b")")
                       .decode("latin-1"))  # fmt: skip
    return "\n".join(out)


def test_the_pdf_holds_the_same_on_a4_pages(report):
    d, result, page = report
    pdf = d / "out" / "report.pdf"
    raw = pdf.read_bytes()
    assert raw.startswith(b"%PDF") and raw.rstrip().endswith(b"%%EOF")
    figures = len(re.findall(r"<figure id='figure-", page.read_text()))
    pages = re.findall(rb"/Type\s*/Page\b", raw)
    # the verdict, the parameters (9 rows), the test, the runs, one page per figure, the
    # provenance (no held-out validation here)
    assert result.holdout is None
    assert len(pages) >= 5 + figures
    boxes = re.findall(rb"/MediaBox\s*\[\s*0 0 ([\d.]+) ([\d.]+)\s*\]", raw)
    sizes = [(round(float(w)), round(float(h))) for w, h in boxes]
    # A4: text pages upright, the wide figures (the parameters' 15 x 5.8 in) turned
    assert set(sizes) == {(595, 842), (842, 595)} and sizes.count((595, 842)) > 5
    info = raw.decode("latin-1")
    assert f"/Author (femcal {__version__})" in info
    assert "/Title (femcal calibration report)" in info
    text = _pdf_text(raw)
    assert f"femcal {__version__}" in text
    assert "Parameters" in text and "Paired modes" in text and "Inputs" in text
    for p in result.parameters:
        assert p.parameter.name in text
    for k in range(1, figures + 1):
        assert f"Figure {k}." in text
    assert hashlib.sha256((d / "main.bdf").read_bytes()).hexdigest()[:20] in text
    assert result.deviation_after and "Deviation" in text  # the summary lines
    assert not list((d / "out").glob(".report.pdf.*"))  # written atomically


def test_the_pdf_holds_every_section_of_the_page(report):
    """Every section and table title of report.html is in report.pdf, the verdict first and
    the provenance last in both."""
    import html

    d, _, page = report
    text = page.read_text()
    titles = [html.unescape(re.sub(r"<[^>]+>", "", t))
              for t in re.findall(r"<h[23][^>]*>(.*?)</h[23]>", text, re.S)]  # fmt: skip
    assert titles[0] == "Verdict" and "Provenance" in titles and "Runs" in titles
    assert "Suspect channels" in titles or "No channel stands out" in text
    pdf = _pdf_text((d / "out" / "report.pdf").read_bytes())
    flat = re.sub(r"\s+", " ", pdf)
    missing = [t for t in titles if re.sub(r"\s+", " ", t) not in flat]
    assert not missing, missing
    assert flat.index("Verdict") < flat.index("Parameters") < flat.index("Runs") \
        < flat.index("Provenance")  # fmt: skip
    # the page's header cells are whole words in the PDF: no header broken mid-word
    for word in ("name", "description", "nominal", "calibrated", "status"):
        assert re.search(rf"(?m)^{word}$", pdf), word


@needs_browser
def test_the_page_opens_on_its_verdict_and_fits_1024_pixels(report, tmp_path):
    _, _, page = report
    assert_verdict_first_at_1024(page, tmp_path / "calibration.png")


def test_long_tables_split_and_no_text_leaves_the_page(report, tmp_path, monkeypatch):
    """Many parameters with long descriptions and long paths: the table goes on over pages,
    each line is wrapped to its column, and every piece of text stays inside the margins."""
    from femcal.io.calibration import report_dict, report_inputs, report_texts
    from femcal.io.html import provenance
    from femcal.viz import report_pdf

    d, result, _ = report
    rep = report_dict(result)
    long = "a description much longer than its column " * 4 + "x" * 120
    rep["parameters"] = [dict(p, name=f"{p['name']}_{k}", description=long)
                         for k in range(8) for p in rep["parameters"]]  # fmt: skip
    rep["summary"] = rep["summary"] + ["w" * 400]
    head = provenance(report_inputs(result), command="femcal calibrate " + "/deep" * 60)
    head["inputs"].append(dict(head["inputs"][0], path="/" + "long_folder_name/" * 20))
    png = d / "out" / "pictures" / "history.png"
    seen: list[tuple[str, float, float, float, float, float, float]] = []
    close = report_pdf._Document.close_page

    def check(doc):
        if doc.fig is not None:  # measured at 720 dpi (the PDF's glyphs are not hinted)
            doc.fig.set_dpi(720)
            renderer = doc.fig.canvas.get_renderer()
            for t in doc.fig.texts:
                box = t.get_window_extent(renderer)
                seen.append((t.get_text(), *(v / 10 for v in (box.x0, box.x1, box.y0,
                                                              box.y1)),
                             doc.page_w, doc.page_h))  # fmt: skip
            doc.fig.set_dpi(72)
        close(doc)

    monkeypatch.setattr(report_pdf._Document, "close_page", check)
    out = report_pdf.write_report_pdf(tmp_path / "r.pdf", rep, head,
                                      [(1, "History " * 30, png, "A caption. " * 200)],
                                      texts=report_texts(rep))  # fmt: skip
    assert out.pages.count("parameters") >= 3 and out.pages[-2:] == ("figure 1", "provenance")
    raw = out.path.read_bytes()
    assert len(re.findall(rb"/Type\s*/Page\b", raw)) == len(out.pages)
    m = report_pdf.MARGIN - 0.5
    for s, x0, x1, y0, y1, width, height in seen:  # on a portrait or a landscape page
        assert x0 >= m and x1 <= width - m, s
        assert y0 >= m / 2 - 6 and y1 <= height - m, s
    assert not list(tmp_path.glob(".*"))


def test_rig_pages_embed_their_pictures(tmp_path):
    """The drive iteration's and the comparison's pages: each picture numbered and embedded,
    the header naming femcal and the target file."""
    from femcal.io.rig import write_comparison_html, write_iteration_html
    from femcal.viz.figures import pyplot, save_figure

    plt = pyplot()
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set(xlabel="iteration", ylabel="RMS error (%)")
    save_figure(fig, tmp_path / "rms_error.png")
    target = tmp_path / "target.rsp"
    target.write_bytes(b"\0" * 512)
    deck = tmp_path / "rig.bdf"
    deck.write_text("BEGIN BULK\nENDDATA\n")
    settings = {"iterations": 2, "gain": 1.0, "rcond": 1e-3, "band_hz": [1.0, 40.0]}
    it = {"target": str(target), "model": str(deck), "plant": str(deck), "frf": "the model's",
          "settings": settings, "control": [{"channel": "S1", "rms_error": [0.5, 0.1, 0.01]}],
          "drives": [{"actuator": "A1", "unit": "mm", "rms": [1.0, 1.1, 1.1]}],
          "final_rms_error": {"worst": 0.01, "median": 0.01}}  # fmt: skip
    figures = [("Error at each iteration", "rms_error.png", "The error."),
               ("Not drawn", "missing.png", "A picture that is not there.")]
    page = write_iteration_html(tmp_path / "report.html", it, figures).read_text()
    cmp = {"target": str(target), "control": ["S1"], "settings": settings, "actuators": ["A1"],
           "models": [{"name": "plain", "control_rms_error": [0.01],
                       "uncontrolled_rms_error": {}}]}  # fmt: skip
    page2 = write_comparison_html(tmp_path / "compare.html", cmp, figures[:1]).read_text()
    for text in (page, page2):
        assert outside_references(text) == []
        src = _images(text)
        assert len(src) == 1 and base64.b64decode(src[0].partition(",")[2])[:8] == PNG
        assert "Figure 1. Error at each iteration" in text
        assert f"femcal {__version__}" in text and "target.rsp" in text
        assert hashlib.sha256(target.read_bytes()).hexdigest() in text
    assert "Figure 2. Not drawn" in page and "missing.png was not drawn" in page
    assert "rig.bdf" in page


def _browser(browser: str, args: list[str]) -> tuple[str, str]:
    """A headless Chromium run in a fresh profile: (stdout, stderr); ended with its helpers
    if it overruns."""
    with tempfile.TemporaryDirectory(prefix="femcal-browser-") as profile:
        cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-extensions", "--hide-scrollbars", "--enable-logging=stderr", "--v=0",
               f"--user-data-dir={profile}", "--virtual-time-budget=5000", *args]  # fmt: skip
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True)  # fmt: skip
        try:
            return proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            raise


BROWSER = find_browser()


@pytest.mark.skipif(BROWSER is None, reason="no chromium to open the page in "
                    "(apt-get install -y chromium)")  # fmt: skip
def test_the_page_opens_in_a_browser_with_every_picture_and_no_console_error(report,
                                                                            tmp_path):  # fmt: skip
    _, _, page = report
    # a copy away from the pictures folder, with a line of script that counts the pictures
    # the browser decoded
    probe = ("<script>addEventListener('load', () => document.documentElement.setAttribute("
             "'data-pictures', [...document.images].filter(i => i.complete && "
             "i.naturalWidth > 0).length + '/' + document.images.length));</script>")
    copy = tmp_path / "sent" / "report.html"
    copy.parent.mkdir()
    copy.write_text(page.read_text().replace("</body>", probe + "</body>"))
    dom, err = _browser(BROWSER, ["--dump-dom", copy.resolve().as_uri()])
    count = re.search(r'data-pictures="(\d+)/(\d+)"', dom)
    assert count and count.group(1) == count.group(2) and int(count.group(2)) >= 6, dom[:300]
    shot = tmp_path / "shot.png"
    _, err2 = _browser(BROWSER, ["--window-size=1280,2000", f"--screenshot={shot}",
                                 page.resolve().as_uri()])  # fmt: skip
    console = re.findall(r":CONSOLE[^\]]*\]\s*(.*)", err + err2)
    assert console == []
    assert shot.read_bytes()[:8] == PNG and shot.stat().st_size > 20_000


def test_the_identification_it_ran_has_its_own_page(report):
    d, result, _ = report
    page = (d / "out" / "identify" / "identification.html").read_text()
    assert page.index("<h2>Verdict</h2>") < page.index("id='modes'") < page.index(
        "id='provenance'")
    k = len(result.cases[0].identified.frequency_hz)
    assert f"<td>{k} in 10-560 Hz" in page and outside_references(page) == []


def test_the_paired_modes_are_drawn_in_the_3d_viewer(report):
    _, result, page = report
    case = result.cases[0]
    view = read_webview(page)
    paired = [m for m in case.modes if m.fe_after is not None]
    o = view["overlay"]
    assert [p["label"].split(" / ")[0] for p in o["pairs"]] == [
        f"test {m.test_mode} ({m.test_hz:.2f} Hz)" for m in paired]
    numbers = [m["mode"] for m in view["modes"]]
    assert [numbers[p["mode"]] for p in o["pairs"]] == [m.fe_after for m in paired]
    np.testing.assert_allclose([m["frequency_hz"] for m in view["modes"]],
                               case.modes_after.frequencies_hz[np.array(numbers) - 1])
    # the plate's shells as faces, the sensors named by the sensors file
    assert view["n_faces"] > 0 and set(o["sensor_names"]) == {
        f"S{g:02d}" for g in {c.grid for c in case.outputs}}
    # the test shape scaled to the FE shape agrees with it as the pair's MAC says
    for n, m in enumerate(paired):
        t, f = o["test"][n].ravel(), o["fe"][n].ravel()
        assert (t @ f) ** 2 / ((t @ t) * (f @ f)) == pytest.approx(m.mac_after, abs=0.05)


def test_the_runs_table_sets_like_beside_like(report):
    """Each start's objective at its first and last point side by side, the second never
    above the first, and the deviation apart (541 beside 1281.86 read as a start that got
    worse: two different quantities); the caption says what the objective is, so that an
    objective (Huber's loss) below the deviation (the plain sum of squares) is explained."""
    from femcal.io.calibration import report_dict

    _d, result, page = report
    text = page.read_text()
    for head in ("objective: first point", "objective: last point",
                 "deviation at the last point"):  # fmt: skip
        assert f"<th>{head}</th>" in text
    rep = report_dict(result)
    loss = "Huber loss" if rep["loss"] == "huber" else "the deviation plus the prior"
    assert loss in text.split("objective: first point")[0].rsplit("<table", 1)[0][-900:]
    for s in rep["starts"]:
        assert s["history"][-1] <= s["history"][0]
        table = text.split("objective: first point")[1]
        row = re.search(rf"<tr><td>{s['start'] + 1}</td><td>([^<]*)</td><td>([^<]*)</td>", table)
        assert row is not None and float(row[2]) == pytest.approx(s["history"][-1], rel=1e-5)


def test_the_paired_shapes_name_their_three_farthest_components(report, tmp_path,
                                                                  monkeypatch):  # fmt: skip
    """The caption promises the three components farthest from the diagonal named by their
    sensor: each panel numbers three points, however well the shapes agree, and names them
    in its corner."""
    from matplotlib.text import Annotation, Text

    from femcal.viz import calibration as pictures

    _d, result, _page = report
    case = result.cases[0]
    seen = []
    monkeypatch.setattr(pictures, "save_figure", lambda fig, path, dpi=100: seen.append(fig))
    assert pictures.vector_plot(tmp_path / "v.png", case) is not None
    panels = [ax for ax in seen[0].axes if ax.get_visible()]
    assert len(panels) == len([m for m in case.modes if m.fe_after is not None])
    names = set(case.channel_names.values()) | {c.label for c in case.outputs}
    for ax in panels:
        notes = [c for c in ax.get_children() if isinstance(c, Annotation)]
        n = min(3, len(case.outputs))
        assert [a.get_text() for a in notes] == [str(k) for k in range(1, n + 1)], ax.get_title()
        key = [t.get_text() for t in ax.texts if (type(t) is Text and "\n" in t.get_text())
               or (type(t) is Text and t.get_text()[:2] == "1 ")]  # fmt: skip
        assert len(key) == 1, ax.get_title()
        lines = key[0].split("\n")
        assert [x.split(" ", 1)[0] for x in lines] == [str(k) for k in range(1, n + 1)]
        assert all(x.split(" ", 1)[1] in names for x in lines)


def test_where_the_model_form_warning_points_is_a_doubt_not_a_reassurance():
    from femcal.io.calibration import _is_warning

    assert _is_warning("Model-form warning: the typical misfit after calibration ...")
    assert _is_warning("Where: a point mass of 0.00602 t at GRID 5442 would remove 27 %")
    assert _is_warning("rig: Where: a spring to ground of 2e+08 N mm/rad at GRID 7 ...")
    assert not _is_warning("Held-out prediction: calibrated without each input's FRFs ...")
    assert not _is_warning("The search settled: the identifiable parameters stopped moving.")


def _greedy_wrap(measure, text: str, width: float, size: float, weight: str, family: str):
    """The plain rule the PDF's wrapping keeps: a word at a time while the line fits, a
    word wider than the line broken between characters."""
    width *= 0.98
    lines = []
    for para in text.split("\n"):
        line = ""
        for word in para.split(" "):
            trial = f"{line} {word}" if line else word
            if measure.width(trial, size, weight, family) <= width:
                line = trial
                continue
            if line:
                lines.append(line)
            line = ""
            for ch in word:
                if line and measure.width(line + ch, size, weight, family) > width:
                    lines.append(line)
                    line = ch
                else:
                    line += ch
        lines.append(line)
    return lines


def test_the_pdf_wraps_text_as_a_word_at_a_time_would():
    """Wrapping from the words' widths, checked on the line, gives the lines of the plain
    word-at-a-time rule: long and short words, double spaces, newlines, words wider than
    the line, both fonts and weights."""
    from femcal.viz.report_pdf import _Measure

    rng = np.random.default_rng(7)
    vocab = ["a", "of", "the", "frequency", "0.00913", "(12957:3)", "misfit", "MAC", "p29",
             "antiresonances,", "W" * 12, "i" * 40, "x" * 150, "", "calibration:"]
    measure, reference = _Measure(), _Measure()
    for _ in range(40):
        words = rng.choice(vocab, size=int(rng.integers(0, 50)))
        seps = rng.choice([" ", " ", " ", "  ", "\n", " \n "], size=len(words))
        text = "".join(w + s for w, s in zip(words, seps, strict=True))
        width = float(rng.uniform(40.0, 500.0))
        size = float(rng.choice([7.0, 9.5, 12.0]))
        weight = str(rng.choice(["normal", "bold"]))
        family = str(rng.choice(["sans-serif", "monospace"]))
        assert measure.wrap(text, width, size, weight, family) == _greedy_wrap(
            reference, text, width, size, weight, family)
