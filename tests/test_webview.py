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
from femcal.correlate.shapes import RIGID_SHARE, rigid_share
from femcal.io.modes import basic_translations
from femcal.io.uff_shapes import mesh_edges
from femcal.model.build import load_model
from femcal.solve.normal_modes import solve_normal_modes
from femcal.viz.webview import (
    EDGE_ELEMENT,
    EDGE_RIGID,
    EDGE_SURFACE,
    MARKER_GROUND_SPRING,
    MARKER_MASS,
    browser_check,
    external_references,
    find_browser,
    free_rigid_motions,
    read_webview,
    render_page,
    viewer_mesh,
    webview_data,
    write_webview,
)

from .conftest import solve_cantilever
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


#: A free body of shells and solids: two CQUAD4 and two CTRIA3 in z = 0, two CHEXA stacked
#: on the plate's end (the second triangle on the lower one's bottom: no hinge) and a
#: CPENTA on them (its side face on the upper CHEXA's top).
BLOCK = """SOL 103
CEND
METHOD = 1
BEGIN BULK
EIGRL,1,,,10
MAT1,1,210000.,,0.3,7.85-9
PSHELL,1,1,2.,1,,1
PSOLID,2,1
GRID,1,,0.,0.,0.
GRID,2,,50.,0.,0.
GRID,3,,100.,0.,0.
GRID,4,,0.,10.,0.
GRID,5,,50.,10.,0.
GRID,6,,100.,10.,0.
GRID,7,,-20.,5.,0.
GRID,8,,110.,0.,0.
GRID,9,,110.,10.,0.
GRID,10,,100.,0.,10.
GRID,11,,110.,0.,10.
GRID,12,,110.,10.,10.
GRID,13,,100.,10.,10.
GRID,14,,100.,0.,20.
GRID,15,,110.,0.,20.
GRID,16,,110.,10.,20.
GRID,17,,100.,10.,20.
GRID,18,,105.,0.,30.
GRID,19,,105.,10.,30.
CQUAD4,1,1,1,2,5,4
CQUAD4,2,1,2,3,6,5
CTRIA3,3,1,1,4,7
CTRIA3,7,1,3,8,9
CHEXA,4,2,3,8,9,6,10,11,+
+,12,13
CHEXA,5,2,10,11,12,13,14,15,+
+,16,17
CPENTA,6,2,14,15,18,17,16,19
ENDDATA
"""


def test_faces_of_shells_and_the_outer_faces_of_solids(tmp_path):
    deck = tmp_path / "block.bdf"
    deck.write_text(BLOCK)
    model = load_model(deck)
    mesh = viewer_mesh(model)
    faces = [tuple(mesh.grid_ids[f].tolist()) for f in mesh.faces]
    corners = [frozenset(f) for f in faces]
    # 2 quads and 2 triangles; 2 x 6 hexahedron faces and 5 wedge faces less the 2 shared
    # faces, each counted twice
    assert len(faces) == 4 + 12 + 5 - 4 == len(set(corners))
    assert frozenset({10, 11, 12, 13}) not in corners  # between the two CHEXA
    assert frozenset({14, 15, 16, 17}) not in corners  # between the CHEXA and the CPENTA
    assert {frozenset({1, 4, 7}), frozenset({14, 15, 18}), frozenset({16, 17, 19}),
            frozenset({3, 8, 9, 6}), frozenset({3, 8, 9})} <= set(corners)  # fmt: skip
    # every side of every face is an element edge, so no face is a bow-tie
    edges = {frozenset(e) for e in mesh.grid_ids[mesh.edges].tolist()}
    for f in faces:
        ring = list(dict.fromkeys(f))
        assert all(frozenset(p) in edges for p in zip(ring, ring[1:] + ring[:1], strict=True)), f
    assert (mesh.edge_kind == EDGE_SURFACE).all() and mesh.unit == "mm"


def test_the_page_starts_on_the_first_flexible_mode(tmp_path, ladder):
    deck = tmp_path / "block.bdf"
    deck.write_text(BLOCK)
    model = load_model(deck)
    modes, _ = solve_normal_modes(model)
    d = webview_data(modes, model)
    assert [m["rigid"] for m in d["modes"]] == [True] * 6 + [False] * 4  # a free body
    assert d["start"] == 6 and d["n_faces"] == 17 and free_rigid_motions(modes, model) == 6 and d["shape_unit"] == "mm/\u221at"
    # the ladder frame on four soft springs: its five lowest modes swing it rigidly
    model, modes = ladder
    d = webview_data(modes, model)
    assert [m["rigid"] for m in d["modes"]][:6] == [True] * 5 + [False]
    assert d["start"] == 5 and d["unit"] == "mm"
    # springs hold it; the one support (SPC1 1 at grid 201, the front cross member held
    # fore and aft) fixes one rigid motion
    assert free_rigid_motions(modes, model) == 5


def test_a_clamped_model_has_no_rigid_body_mode():
    # the cantilever's first bending mode is nearly a turn about its root (a rigid motion
    # explains over 95 % of it), but the clamp leaves no rigid motion free
    model, _, modes, _ = solve_cantilever(coupled_mass=True, n_modes=4)
    grids = np.flatnonzero(model.is_grid)
    shapes = np.moveaxis(basic_translations(modes, model)[grids], 2, 0)
    assert rigid_share(model.xyz[grids], shapes)[0] > RIGID_SHARE
    assert free_rigid_motions(modes, model) == 0
    d = webview_data(modes, model)
    assert not any(m["rigid"] for m in d["modes"]) and d["start"] == 0


def test_zero_frequency_modes_are_not_opened_on_whatever_their_shape(ladder):
    """A mechanism (or a rigid-body mode a rigid motion does not explain, a hair below zero)
    is marked as at zero frequency and the page opens after it."""
    from femcal.viz.webview import near_zero, viewer_data, viewer_mesh

    assert near_zero(np.array([-1e-5, 2e-4, 0.5, 2.0, 100.0])).tolist() == [
        True, True, False, False, False]
    assert near_zero(np.array([-0.004, 0.09, 0.2, 1e3])).tolist() == [True, True, False, False]
    model, modes = ladder
    mesh = viewer_mesh(model)
    grids = np.flatnonzero(model.is_grid)
    disp = np.moveaxis(basic_translations(modes, model)[grids], 2, 0)
    # modes 6 and 7 (flexible shapes) given zero frequencies, one of them a hair below zero
    f = np.array(modes.frequencies_hz, float)
    f[5], f[6] = -1e-5, 2e-5
    d = viewer_data(mesh, disp, f, free_rigid=5)
    assert [m["zero"] for m in d["modes"]][:8] == [False] * 5 + [True, True, False]
    assert d["start"] == 7


@needs_browser
def test_shaded_surfaces_a_triad_and_picking_in_a_headless_browser(tmp_path):
    from PIL import Image

    deck = tmp_path / "block.bdf"
    deck.write_text(BLOCK)
    model = load_model(deck)
    modes, _ = solve_normal_modes(model)
    page = write_webview(tmp_path / "block.html", modes, model, title="block")
    r = browser_check(page, browser=BROWSER, screenshot=tmp_path / "shot.png")
    # the self-test clicks the grid nearest the eye and reads its id back, checks the
    # triad, the wireframe and the shaded drawing of every mode
    assert r.ok, r
    assert (r.faces, r.modes, r.start) == (17, 10, 7)  # opened on the first flexible mode
    img = np.asarray(Image.open(r.screenshot).convert("RGB")).astype(int)[60:-60]
    grey = (np.ptp(img, axis=2) < 12) & (img.sum(axis=2) < 700)
    coloured = np.ptp(img, axis=2) > 40
    assert coloured.sum() > 2000 and grey.sum() > 200  # filled faces, lettering and lines
    no_pick = tmp_path / "no_pick.html"
    no_pick.write_text(page.read_text(encoding="utf-8").replace("picked = best >= 0 ?",
                                                                "picked = false ?"))
    r = browser_check(no_pick, browser=BROWSER)
    assert r.selftest.startswith("fail: a click does not name grid")


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
    assert len(full) < 45_000 + 6 * model.n_grids * 3 * len(modes.eigenvalues)


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
