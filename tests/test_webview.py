"""The interactive mode page (issue 27): one self-contained HTML file that reaches nothing
outside it, whose embedded data decode to the solved modes (float32), whose script parses,
and that a headless Chromium runs: it draws, its self-test passes (every mode moves the
model; drag, wheel, double-click, scale, colour), its console stays silent, and a broken page
is caught. ``femcal solve --html``. The browser checks need ``chromium`` (skipped, with the
reason, without it); the rest runs everywhere."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

from femcal.cli import main
from femcal.io.modes import basic_translations
from femcal.io.uff_shapes import mesh_edges
from femcal.model.build import load_model
from femcal.solve.normal_modes import solve_normal_modes
from femcal.viz.webview import (
    EDGE_ELEMENT,
    EDGE_RIGID,
    MARKER_GROUND_SPRING,
    MARKER_MASS,
    browser_check,
    external_references,
    find_browser,
    read_webview,
    render_page,
    webview_data,
    write_webview,
)

from .test_punch import LADDER

BROWSER = find_browser()
needs_browser = pytest.mark.skipif(BROWSER is None, reason="no chromium to run the page in "
                                   "(apt-get install -y chromium)")  # fmt: skip


@pytest.fixture(scope="module")
def ladder():
    model = load_model(LADDER)
    modes, _ = solve_normal_modes(model)
    return model, modes


@pytest.fixture(scope="module")
def page(ladder, tmp_path_factory):
    model, modes = ladder
    return write_webview(tmp_path_factory.mktemp("page") / "ladder.html", modes, model,
                         title="ladder_frame.bdf <&>")  # fmt: skip


def script_of(text: str) -> str:
    return text[text.rindex("<script>") + len("<script>") : text.rindex("</script>")]


def test_page_reaches_nothing_outside_its_file(page):
    text = page.read_text(encoding="utf-8")
    assert external_references(text) == []
    lowered = text.lower()
    for bad in ("http:", "https:", "src=", "href=", "<link", "@import", "url("):
        assert bad not in lowered
    assert text.count("<script") == 2  # the data block and the inline script, no src
    assert "<title>femcal modes: ladder_frame.bdf &lt;&amp;&gt;</title>" in text
    assert "ladder_frame.bdf \\u003c&>" in text  # the title in the data cannot end a script
    # the checker itself finds what a page must not have
    assert len(external_references('<script src="//cdn.example/x.js"></script>')) == 1
    assert external_references("<style>@font-face{src:url(f.woff)}</style>")
    assert external_references("<a href='https://example.org'>x</a>")


def test_embedded_data_decode_to_the_solved_modes(page, ladder):
    model, modes = ladder
    d = read_webview(page)
    k = len(modes.eigenvalues)
    assert d["n_modes"] == k == 12 and d["title"] == "ladder_frame.bdf <&>"
    grids = np.flatnonzero(model.is_grid)
    np.testing.assert_array_equal(d["grid_ids"], model.node_ids[grids])
    np.testing.assert_array_equal(d["points"], model.xyz[grids].astype(np.float32))
    want = np.moveaxis(basic_translations(modes, model)[grids], 2, 0)  # (k, P, 3)
    umax = np.linalg.norm(want, axis=2).max(axis=1)
    np.testing.assert_array_equal([m["max"] for m in d["modes"]], umax)
    np.testing.assert_array_equal(d["unit_shapes"], (want / umax[:, None, None]).astype("f4"))
    err = np.abs(d["shapes"] - want).max(axis=(1, 2)) / umax
    assert err.max() <= 2.0**-24  # float32 rounding of shapes whose largest is 1
    np.testing.assert_array_equal([m["frequency_hz"] for m in d["modes"]], modes.frequencies_hz)
    assert [m["mode"] for m in d["modes"]] == list(range(1, k + 1))
    # lines: the 36 CBARs and the RBE2's three legs, each once; the springs go to ground
    pairs = np.sort(d["grid_ids"][d["edges"]], axis=1)
    np.testing.assert_array_equal(np.unique(pairs, axis=0), mesh_edges(model))
    assert len(pairs) == 39
    rigid = {tuple(p) for p in pairs[d["edge_kind"] == EDGE_RIGID].tolist()}
    assert rigid == {(7, 301), (8, 301), (9, 301)}
    assert (d["edge_kind"] == EDGE_ELEMENT).sum() == 36
    marks = d["grid_ids"][d["markers"]]
    assert marks[d["marker_kind"] == MARKER_MASS].tolist() == [301]
    assert sorted(set(marks[d["marker_kind"] == MARKER_GROUND_SPRING].tolist())) == [2, 14, 102,
                                                                                     114]


def test_fewer_modes_and_the_hammer_frames_budget(ladder):
    model, modes = ladder
    d = webview_data(modes, model, max_modes=3)
    assert d["n_modes"] == 3 and len(d["modes"]) == 3
    back = read_webview(render_page(d))
    assert back["shapes"].shape == (3, model.n_grids, 3)
    # the page is about 4 bytes x 4/3 per grid, direction and mode, plus the script
    full = render_page(webview_data(modes, model, max_modes=None))
    assert len(full) < 30_000 + 6 * model.n_grids * 3 * len(modes.eigenvalues)


def test_the_script_parses(page):
    node = shutil.which("node")
    if node is None and BROWSER is None:
        pytest.skip("neither node nor chromium to parse the script")
    if node is None:
        return  # the browser tests parse and run it
    js = page.parent / "script.js"
    js.write_text(script_of(page.read_text(encoding="utf-8")))
    r = subprocess.run([node, "--check", str(js)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    js.write_text(script_of(page.read_text(encoding="utf-8")) + "\nvar = ;\n")
    r = subprocess.run([node, "--check", str(js)], capture_output=True, text=True, timeout=60)
    assert r.returncode != 0  # the check can fail


@needs_browser
def test_the_page_runs_in_a_headless_browser(page, tmp_path):
    from PIL import Image

    r = browser_check(page, browser=BROWSER, screenshot=tmp_path / "shot.png")
    assert r.status == "ok", r
    assert r.selftest == "pass", r.selftest
    assert r.console == (), r.console
    assert (r.edges, r.modes) == (39, 12) and r.ink > 500
    img = np.asarray(Image.open(r.screenshot).convert("RGB")).astype(int)[40:-40]
    assert (img.sum(axis=2) < 600).sum() > 500  # the model is drawn, not a blank page
    assert r.ok


@needs_browser
def test_the_browser_check_catches_a_broken_page(page, tmp_path):
    text = page.read_text(encoding="utf-8")
    no_zoom = tmp_path / "no_zoom.html"
    no_zoom.write_text(text.replace("view.zoom * Math.exp(-ev.deltaY * 0.0015)", "view.zoom"))
    r = browser_check(no_zoom, browser=BROWSER)
    assert r.status == "ok" and r.selftest == "fail: the wheel does not zoom" and not r.ok
    broken = tmp_path / "broken.html"
    broken.write_text(text.replace('"use strict";', '"use strict"; var = ;'))
    r = browser_check(broken, browser=BROWSER)
    assert r.status == "" and any("Uncaught SyntaxError" in m for m in r.console)
    bad_data = tmp_path / "bad_data.html"
    bad_data.write_text(text.replace('"n_points":35', '"n_points":36'))
    r = browser_check(bad_data, browser=BROWSER)
    assert r.status.startswith("error:") and "sizes" in r.status


def test_solve_writes_the_page_from_the_command_line(tmp_path, capsys, ladder):
    model, modes = ladder
    path = tmp_path / "ladder.html"
    assert main(["solve", str(LADDER), "--html", str(path)]) == 0
    assert f"wrote {path}" in capsys.readouterr().err
    d = read_webview(path)
    np.testing.assert_allclose(d["shapes"][0], basic_translations(modes, model)[:, :, 0],
                               rtol=0, atol=2.0**-24 * d["modes"][0]["max"])  # fmt: skip
    assert not list(tmp_path.glob(".*"))
    assert main(["solve", str(LADDER), "--html", str(tmp_path / "page.txt")]) == 2
    assert "expected .html or .htm" in capsys.readouterr().err
