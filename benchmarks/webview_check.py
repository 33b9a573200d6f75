"""The interactive mode page (``femcal solve DECK --html FILE``, :mod:`femcal.viz.webview`)
checked in a real browser (issue 27).

    .venv/bin/python benchmarks/webview_check.py                 # the ladder frame
    .venv/bin/python benchmarks/webview_check.py --hammer        # the hammer frame (16 059 grids)
    .venv/bin/python benchmarks/webview_check.py --deck DECK [--max-modes N] [--out DIR]

Solves the deck, writes the page and checks, printing each check:

1. the page reaches nothing outside its file (no URL, no src/href, no import, request or
   worker; :func:`femcal.viz.webview.external_references`);
2. its embedded data decode to the solved modes: grid coordinates and every mode's
   translations in basic to float32 precision, the frequencies exactly, the edges those of
   the mesh (element edges, rigid elements' legs, springs);
3. in a headless Chromium (``apt-get install -y chromium``): the script ran
   (``data-femcal="ok"``), its self-test passed (every mode draws and moves the model, a
   drag rotates, the wheel zooms, a double-click resets, scale 0 undeforms, the uncoloured
   drawing is not empty), the console stayed silent (no uncaught error, no warning);
4. the screenshot (animation off, mode 1) shows the model: enough dark and coloured pixels
   in the drawing area.

Exits 0 when every check passes, 1 when one fails (a missing browser is a failure: install
it, or run ``tests/test_webview.py``, which checks 1 and 2 without it). The page, the
screenshot and ``webview_check.json`` go to ``--out`` (default benchmarks/_work/webview).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
LADDER = ROOT / "models" / "examples" / "ladder_frame.bdf"
HAMMER = ROOT / "models" / "truck_frame" / "hammer_frame.bdf"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--deck", type=Path, default=LADDER)
    ap.add_argument("--hammer", action="store_true", help="the hammer frame instead")
    ap.add_argument("--max-modes", type=int, default=None, help="modes in the page (default 20)")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "_work" / "webview")
    args = ap.parse_args(argv)
    deck = HAMMER if args.hammer else args.deck

    from femcal.io.modes import basic_translations
    from femcal.io.uff_shapes import mesh_edges
    from femcal.model.build import load_model
    from femcal.solve.normal_modes import solve_normal_modes
    from femcal.viz.webview import (
        MAX_MODES,
        browser_check,
        external_references,
        find_browser,
        read_webview,
        write_webview,
    )

    failures: list[str] = []
    results: dict = {"deck": str(deck)}

    def check(name: str, ok: bool | np.bool_, detail: str = "") -> None:
        ok = bool(ok)
        print(f"  [{'pass' if ok else 'FAIL'}] {name}" + (f": {detail}" if detail else ""))
        results.setdefault("checks", []).append({"check": name, "ok": ok, "detail": detail})
        if not ok:
            failures.append(name)

    t = time.perf_counter()
    model = load_model(deck)
    modes, _ = solve_normal_modes(model)
    t_solve = time.perf_counter() - t
    print(f"{deck.name}: {model.n_grids} grids, {len(modes.eigenvalues)} modes solved in "
          f"{t_solve:.1f} s")  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    page = args.out / f"{deck.stem}.html"
    n_max = MAX_MODES if args.max_modes is None else args.max_modes
    t = time.perf_counter()
    write_webview(page, modes, model, title=deck.name, max_modes=n_max)
    t_write = time.perf_counter() - t
    size = page.stat().st_size
    results.update(page=str(page), bytes=size, write_s=t_write, solve_s=t_solve)
    print(f"wrote {page} ({size / 1e6:.2f} MB) in {t_write:.2f} s")

    print("the page on its own:")
    text = page.read_text(encoding="utf-8")
    ext = external_references(text)
    check("no external references", not ext, "; ".join(ext[:3]))
    d = read_webview(page)
    grids = np.flatnonzero(model.is_grid)
    n = min(n_max, len(modes.eigenvalues))
    check("modes in the page", d["n_modes"] == n, f"{d['n_modes']} of {len(modes.eigenvalues)}")
    err = np.abs(d["points"] - model.xyz[grids])
    check("grid coordinates (float32)", np.all(err <= 2.0**-24 * np.abs(model.xyz[grids])),
          f"largest error {float(err.max()):.2e}")  # fmt: skip
    check("grid ids", np.array_equal(d["grid_ids"], model.node_ids[grids]))
    want = np.moveaxis(basic_translations(modes, model)[grids][:, :, :n], 2, 0)
    scale = np.linalg.norm(want, axis=2).max(axis=1)
    rel = float((np.abs(d["shapes"] - want).max(axis=(1, 2)) / scale).max()) if n else 0.0
    check("mode shapes in basic (float32)", rel <= 2.0**-23, f"largest relative error {rel:.1e}")
    f_page = np.array([m["frequency_hz"] for m in d["modes"]])
    check("frequencies", np.array_equal(f_page, modes.frequencies_hz[:n]))
    drawn = {tuple(sorted(p)) for p in d["grid_ids"][d["edges"]].tolist()}
    mesh = {tuple(p) for p in mesh_edges(model).tolist()}
    check("edges: the mesh's element edges and rigid legs (and springs)", mesh <= drawn,
          f"{len(drawn)} lines, {int((d['edge_kind'] == 1).sum())} rigid, "
          f"{int((d['edge_kind'] == 2).sum())} springs, {len(d['markers'])} markers")  # fmt: skip

    print("in a browser:")
    browser = find_browser()
    if browser is None:
        check("a headless browser", False, "none found: apt-get install -y chromium")
    else:
        shot = args.out / f"{deck.stem}.png"
        t = time.perf_counter()
        r = browser_check(page, browser=browser, screenshot=shot)
        t_browser = time.perf_counter() - t
        results.update(browser=browser, browser_s=t_browser, ink=r.ink)
        print(f"  ({browser}, both runs {t_browser:.1f} s)")
        check("the script ran and drew", r.status == "ok" and r.ink > 0,
              f"status {r.status!r}, {r.ink} dark pixels, {r.edges} lines, {r.modes} modes")
        check("self-test (modes, drag, wheel, double-click, a click names a grid, the triad, "
              "scale, colour, wireframe)", r.selftest == "pass",
              r.selftest or "did not run")  # fmt: skip
        rigid = [m["mode"] for m in d["modes"] if m["rigid"]]
        check("opens on the first flexible mode", r.start == (rigid[-1] + 1 if rigid else 1),
              f"mode {r.start}; rigid-body modes {rigid or 'none'}; {r.faces} faces")
        times = _drawing_ms(page, browser)
        results.update(draw_ms=times)
        print(f"  one drawing of the mode (headless, software): {times['surfaces']:.0f} ms "
              f"shaded, {times['wireframe']:.0f} ms wireframe")  # fmt: skip
        check("no console messages", not r.console, "; ".join(r.console[:3]))
        if r.screenshot is None:
            check("screenshot", False, "the browser wrote none")
        else:
            from PIL import Image

            img = np.asarray(Image.open(r.screenshot).convert("RGB")).astype(int)
            body = img[40:-40]  # the drawing, between the controls and the help line
            dark = int((body.sum(axis=2) < 600).sum())
            colour = int((body.max(axis=2) - body.min(axis=2) > 60).sum())
            results.update(screenshot=str(r.screenshot), dark_pixels=dark, colour_pixels=colour)
            check("screenshot shows the model", dark > 500 and colour > 300,
                  f"{r.screenshot}: {dark} dark, {colour} coloured pixels")  # fmt: skip
    results["failures"] = failures
    (args.out / "webview_check.json").write_text(json.dumps(results, indent=1))
    print("all checks passed" if not failures else f"{len(failures)} check(s) failed")
    return 1 if failures else 0


_TIMER = """<script>
(function () {
  var box = document.querySelector(".femcal-viewer"), sel = box.querySelector(".fv-mode");
  function time() {
    var t = performance.now();
    for (var i = 0; i < 10; i++) {
      sel.value = String(i % sel.options.length); sel.dispatchEvent(new Event("change"));
    }
    return (performance.now() - t) / 10;
  }
  var shaded = time();
  box.querySelector(".fv-surf").checked = false;
  document.documentElement.setAttribute("data-draw-ms", shaded + " " + time());
})();
</script></body>"""


def _drawing_ms(page: Path, browser: str) -> dict[str, float]:
    """Milliseconds per drawing of a mode (animation off, ten drawings), shaded and as a
    wireframe, in the headless browser (software rendering: a desktop's is faster)."""
    import re
    import tempfile

    from femcal.viz.webview import _run_browser

    with tempfile.TemporaryDirectory() as tmp:
        timed = Path(tmp) / "timed.html"
        timed.write_text(page.read_text(encoding="utf-8").replace("</body>", _TIMER, 1),
                         encoding="utf-8")  # fmt: skip
        dom, _ = _run_browser(browser, ["--window-size=1200,800", "--dump-dom",
                                        timed.resolve().as_uri() + "#still"], 120.0)  # fmt: skip
    m = re.search(r'data-draw-ms="([\d.]+) ([\d.]+)"', dom)
    if m is None:
        return {"surfaces": float("nan"), "wireframe": float("nan")}
    return {"surfaces": float(m.group(1)), "wireframe": float(m.group(2))}


if __name__ == "__main__":
    sys.exit(main())
