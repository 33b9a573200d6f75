"""An interactive 3-D page of mode shapes: one self-contained HTML file, no server.

:func:`write_webview` writes a page that any current browser opens from disk: no external
script, style sheet, font or network request; the model and its modes are in the file, drawn
by a few hundred lines of vanilla JavaScript on a ``<canvas>`` (an orthographic projection of
the model's lines). The page has:

- the element edges (those of :func:`femcal.io.uff_shapes.mesh_edges`: solids' corner edges,
  shell sides, bars), rigid elements' legs (RBE2, RBAR, RBE3; dashed red) and springs
  between two grids (CELAS1/2, CBUSH; orange) as lines; masses (CONM1/2) and springs to
  ground as small squares;
- a mode selector with each mode's frequency, animation on or off (one period in 2 s:
  the shape times sin(2 pi t / 2 s)), a scale slider (the largest displacement as a fraction
  of the model's size, 0.08 to start, as :func:`femcal.viz.render.render_modes` draws it),
  colouring by displacement magnitude (viridis) on or off, the undeformed edges faint;
- mouse drag to rotate, shift-drag (or the right button) to pan, the wheel to zoom,
  double-click to return to the isometric view.

The data are one JSON block (``<script type="application/json" id="femcal-data">``) whose
arrays are base64 of little-endian binary: grid coordinates in basic (float32, the model's
units), grid ids (int32), edges (uint32 pairs of grid rows), each mode's translations in
basic at every grid (float32, divided by the mode's largest translation, ``modes[i].max``,
so each mode's largest is 1). :func:`read_webview` decodes them. The page sets
``data-femcal="ok"`` on its ``<html>`` element once it has drawn (``"error: ..."`` on a
script error); ``#still`` after the file name starts it with the animation off, and
``#selftest`` (or ``#still-selftest``) also steps through the modes,
drives the mouse handlers and sets ``data-femcal-selftest`` to ``pass`` or
``fail: <reasons>``. :func:`browser_check` opens a page so in a headless Chromium and reports
both, the console's messages and a screenshot (``benchmarks/webview_check.py``).

Size: 16 bytes per grid and mode (float32 x 3 in base64) plus the grids and edges: the hammer
frame (16 059 grids, 32 239 lines, its 14 modes to 150 Hz) makes a page of 4.3 MB, written in
0.1 s; 20 modes would make 5.9 MB.
"""

from __future__ import annotations

import base64
import html
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..io.modes import RIGID_TYPES, basic_translations, element_cells
from ..io.uff_shapes import mesh_edges
from ..model.model import Model
from ..solve.normal_modes import Modes

#: Modes a page holds unless told otherwise (20 keep the hammer frame's page under 6 MB).
MAX_MODES = 20
#: Edge kinds of the page's ``edge_kind`` array.
EDGE_ELEMENT, EDGE_RIGID, EDGE_SPRING = 0, 1, 2
#: Marker kinds of the page's ``marker_kind`` array.
MARKER_MASS, MARKER_GROUND_SPRING = 0, 1
_SPRING_TYPES = ("CELAS1", "CELAS2", "CBUSH")
_MASS_TYPES = ("CONM1", "CONM2")


def _b64(a: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _unb64(s: str, dtype: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(s), dtype=dtype)


def webview_data(
    modes: Modes, model: Model, *, title: str = "", max_modes: int | None = MAX_MODES
) -> dict:
    """The page's data block as a JSON-ready dict (see the module's description)."""
    grids = np.flatnonzero(model.is_grid)
    if not len(grids):
        raise ValueError("the model has no grids to draw")
    row = np.full(model.n_nodes, -1, np.int64)
    row[grids] = np.arange(len(grids))
    blocks = element_cells(model)
    pairs = model.node_index(mesh_edges(model).ravel()).reshape(-1, 2)
    springs = [b.nodes for b in blocks if b.element_type in _SPRING_TYPES and b.kind == "line"]
    if springs:
        pairs = np.vstack([pairs, *springs])
    pairs = np.sort(pairs, axis=1)
    pairs = pairs[(pairs[:, 0] != pairs[:, 1]) & model.is_grid[pairs].all(axis=1)]
    pairs = np.unique(pairs, axis=0) if len(pairs) else np.zeros((0, 2), np.int64)

    def keys(p: np.ndarray) -> np.ndarray:
        return p[:, 0] * model.n_nodes + p[:, 1]

    def kind_pairs(types: tuple[str, ...]) -> np.ndarray:
        got = [np.sort(b.nodes, axis=1) for b in blocks
               if b.element_type in types and b.kind == "line"]  # fmt: skip
        return keys(np.vstack(got)) if got else np.zeros(0, np.int64)

    element = [np.sort(b.nodes[:, list(e)], axis=1) for b in blocks
               if b.element_type not in (*RIGID_TYPES, *_SPRING_TYPES)
               for e in _edge_list(b.kind)]  # fmt: skip
    element_keys = keys(np.vstack(element)) if element else np.zeros(0, np.int64)
    k = keys(pairs)
    kind = np.full(len(pairs), EDGE_ELEMENT, np.uint8)
    kind[np.isin(k, kind_pairs(_SPRING_TYPES)) & ~np.isin(k, element_keys)] = EDGE_SPRING
    kind[np.isin(k, kind_pairs(RIGID_TYPES)) & ~np.isin(k, element_keys)] = EDGE_RIGID

    markers, marker_kind = [], []
    for b in blocks:
        if b.kind != "vertex":
            continue
        if b.element_type in _MASS_TYPES:
            markers.append(b.nodes[:, 0])
            marker_kind.append(np.full(len(b.nodes), MARKER_MASS, np.uint8))
        elif b.element_type in _SPRING_TYPES:
            markers.append(b.nodes[:, 0])
            marker_kind.append(np.full(len(b.nodes), MARKER_GROUND_SPRING, np.uint8))
    mk = np.concatenate(markers) if markers else np.zeros(0, np.int64)
    mkk = np.concatenate(marker_kind) if marker_kind else np.zeros(0, np.uint8)
    keep = model.is_grid[mk] if len(mk) else np.zeros(0, bool)
    mk, mkk = mk[keep], mkk[keep]

    n_all = len(modes.eigenvalues)
    n_modes = n_all if max_modes is None else min(max_modes, n_all)
    disp = basic_translations(modes, model)[grids][:, :, :n_modes]  # (P, 3, m)
    umax = np.linalg.norm(disp, axis=1).max(axis=0) if len(grids) else np.zeros(n_modes)
    umax = np.where(umax > 0, umax, 1.0)
    shapes = np.moveaxis(disp / umax, 2, 0)  # (m, P, 3)
    xyz = model.xyz[grids]
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    return {
        "format": "femcal-webview 1",
        "title": title,
        "n_points": len(grids),
        "n_edges": len(pairs),
        "n_markers": len(mk),
        "n_modes": n_modes,
        "center": ((lo + hi) / 2).tolist(),
        "size": float(np.ptp(xyz, axis=0).max()) or 1.0,
        "points": _b64(xyz, "<f4"),
        "grid_ids": _b64(model.node_ids[grids], "<i4"),
        "edges": _b64(row[pairs], "<u4"),
        "edge_kind": _b64(kind, "u1"),
        "markers": _b64(row[mk], "<u4"),
        "marker_kind": _b64(mkk, "u1"),
        "modes": [
            {"mode": i + 1, "frequency_hz": float(modes.frequencies_hz[i]), "max": float(umax[i])}
            for i in range(n_modes)
        ],
        "shapes": _b64(shapes, "<f4"),
    }


def _edge_list(kind: str) -> list[tuple[int, int]]:
    """Corner-to-corner pairs of a cell kind (sides of quadratic shells via their corners are
    not needed here: they only tell element edges from rigid legs)."""
    from ..io.uff_shapes import _CORNERS, _EDGES, _SIDES

    if kind in _SIDES:
        return [p for a, m, b in _SIDES[kind] for p in ((a, m), (m, b))]
    return list(_EDGES.get(_CORNERS.get(kind, kind), []))


def render_page(data: dict) -> str:
    """The HTML page of a data block from :func:`webview_data`."""
    blob = json.dumps(data, separators=(",", ":")).replace("<", "\\u003c")
    title = html.escape(f"femcal modes: {data.get('title') or 'model'}")
    return (_PAGE.replace("@TITLE@", title).replace("@DATA@", blob)
            .replace("@SCRIPT@", _SCRIPT.strip()))  # fmt: skip


def write_webview(
    path: Path,
    modes: Modes,
    model: Model,
    *,
    title: str = "",
    max_modes: int | None = MAX_MODES,
) -> Path:
    """Write the page of the first ``max_modes`` modes (all if None) to ``path``, atomically.
    Returns ``path``."""
    page = render_page(webview_data(modes, model, title=title, max_modes=max_modes))

    def w(tmp: str) -> None:
        Path(tmp).write_text(page, encoding="utf-8")

    return write_atomic(path, w)


_DATA_RE = re.compile(r'<script type="application/json" id="femcal-data">(.*?)</script>', re.S)


def read_webview(source: str | Path) -> dict:
    """Decode a page (a path or its text): the data block with its arrays as NumPy arrays:
    ``points`` (P, 3), ``grid_ids`` (P,), ``edges`` (E, 2) rows of ``points``, ``edge_kind``
    (E,), ``markers`` (K,), ``marker_kind`` (K,), ``shapes`` (m, P, 3) the translations in
    basic as solved (the stored unit shapes times each mode's ``max``)."""
    text = Path(source).read_text(encoding="utf-8") if isinstance(source, Path) else source
    m = _DATA_RE.search(text)
    if m is None:
        raise ValueError("no femcal data block in the page")
    d = json.loads(m.group(1))
    p, e, k, nm = d["n_points"], d["n_edges"], d["n_markers"], d["n_modes"]
    out = dict(d)
    out["points"] = _unb64(d["points"], "<f4").reshape(p, 3)
    out["grid_ids"] = _unb64(d["grid_ids"], "<i4")
    out["edges"] = _unb64(d["edges"], "<u4").reshape(e, 2)
    out["edge_kind"] = _unb64(d["edge_kind"], "u1")
    out["markers"] = _unb64(d["markers"], "<u4").reshape(k)
    out["marker_kind"] = _unb64(d["marker_kind"], "u1")
    unit = _unb64(d["shapes"], "<f4").reshape(nm, p, 3)
    scale = np.array([mode["max"] for mode in d["modes"]], dtype=float).reshape(nm, 1, 1)
    out["unit_shapes"] = unit
    out["shapes"] = unit * scale
    return out



#: What would make a page reach outside its file: network and file URLs, attributes that load
#: something, style imports, frames, images, plugins, workers and requests.
_EXTERNAL = re.compile(
    r"""(?ix) (?:https?|ftp|file|data|javascript) \s*: (?=\S)
    | \b(?:src|href|action|poster|srcset|xlink:href) \s*=
    | @import | url\s*\( | <(?:link|iframe|img|object|embed|base|frame|audio|video)\b
    | \bimport\s*\( | \bfetch\s*\( | XMLHttpRequest | WebSocket | EventSource
    | \bnew\s+(?:Shared)?Worker\b | importScripts | navigator\.sendBeacon"""
)


def external_references(text: str) -> list[str]:
    """The places (up to 20, with some context) where a page's markup or script would load
    or send something outside the file (:func:`render_page`'s pages have none). The data
    block is left out: base64 may hold any letters and slashes."""
    text = _DATA_RE.sub("", text)
    return [text[max(0, m.start() - 30) : m.end() + 30].replace("\n", " ")
            for m in _EXTERNAL.finditer(text)][:20]  # fmt: skip


#: Browsers :func:`browser_check` looks for, in this order.
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_browser() -> str | None:
    """The path of a Chromium-family browser on PATH, or None."""
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


@dataclass(frozen=True)
class BrowserCheck:
    """What a headless browser made of a page: ``status`` its ``data-femcal`` (``"ok"``,
    ``"error: ..."``, ``""`` if the script never ran), ``selftest`` its
    ``data-femcal-selftest``, ``ink`` the dark pixels of its first drawing, ``edges`` and
    ``modes`` what it drew from, ``console`` the page's console messages (uncaught errors
    among them; a good page logs none), ``screenshot`` the PNG taken (or None)."""

    status: str
    selftest: str
    ink: int
    edges: int
    modes: int
    console: tuple[str, ...]
    screenshot: Path | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok" and self.selftest == "pass" and not self.console


def _run_browser(browser: str, args: list[str], timeout: float) -> tuple[str, str]:
    """Run the browser headless in a fresh profile; its (stdout, stderr). The browser and
    its helper processes (one process group) are ended if it overruns ``timeout``."""
    with tempfile.TemporaryDirectory(prefix="femcal-browser-") as profile:
        cmd = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-extensions", "--hide-scrollbars", "--enable-logging=stderr", "--v=0",
               f"--user-data-dir={profile}", *args]  # fmt: skip
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True)  # fmt: skip
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            raise RuntimeError(f"{browser} did not finish within {timeout:g} s") from None
    return out, err


def browser_check(
    page: Path,
    *,
    browser: str | None = None,
    screenshot: Path | None = None,
    window: tuple[int, int] = (1200, 800),
    timeout: float = 120.0,
) -> BrowserCheck:
    """Open ``page`` in a headless Chromium with ``#still-selftest`` (the page draws, steps
    through its modes and drives its mouse handlers), read back its marker attributes and
    console messages, and with ``screenshot`` take a PNG of it (animation off, mode 1).
    RuntimeError when there is no browser (``browser`` None: :func:`find_browser`)."""
    browser = browser or find_browser()
    if browser is None:
        raise RuntimeError(f"no browser found (looked for {', '.join(BROWSERS)})")
    url = Path(page).resolve().as_uri()
    size = f"--window-size={window[0]},{window[1]}"
    dom, err = _run_browser(browser, [size, "--dump-dom", url + "#still-selftest"], timeout)
    tag = re.search(r"<html\b[^>]*>", dom)
    attrs = dict(re.findall(r'(data-femcal[a-z-]*)="([^"]*)"', tag.group(0))) if tag else {}
    console = tuple(m.strip() for m in re.findall(r":CONSOLE[^\]]*\]\s*(.*)", err))
    shot = None
    if screenshot is not None:
        screenshot = Path(screenshot).resolve()
        screenshot.parent.mkdir(parents=True, exist_ok=True)
        screenshot.unlink(missing_ok=True)
        _, err2 = _run_browser(browser, [size, f"--screenshot={screenshot}", url + "#still"],
                               timeout)  # fmt: skip
        console += tuple(m.strip() for m in re.findall(r":CONSOLE[^\]]*\]\s*(.*)", err2))
        shot = screenshot if screenshot.exists() else None

    def number(key: str) -> int:
        try:
            return int(attrs.get(key, "0"))
        except ValueError:
            return 0

    return BrowserCheck(html.unescape(attrs.get("data-femcal", "")),
                        html.unescape(attrs.get("data-femcal-selftest", "")),
                        number("data-femcal-ink"), number("data-femcal-edges"),
                        number("data-femcal-modes"), console, shot)  # fmt: skip


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>@TITLE@</title>
<style>
html, body { margin: 0; height: 100%; overflow: hidden; background: #fff; color: #222;
  font: 13px system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; }
#bar { position: absolute; top: 0; left: 0; right: 0; z-index: 1; display: flex;
  flex-wrap: wrap; gap: 14px; align-items: center; padding: 6px 10px;
  background: rgba(255, 255, 255, 0.92); border-bottom: 1px solid #ddd; }
#bar b { font-weight: 600; }
#view { position: absolute; top: 0; left: 0; width: 100%; height: 100%; display: block;
  cursor: grab; touch-action: none; }
#help { position: absolute; bottom: 6px; left: 10px; color: #666; }
#err { color: #b00; font-weight: 600; }
</style>
</head>
<body>
<div id="bar">
  <b id="name"></b>
  <label>Mode <select id="mode"></select></label>
  <label><input type="checkbox" id="anim" checked> animate</label>
  <label>scale <input type="range" id="scale" min="0" max="0.3" step="0.005" value="0.08">
    <span id="scaleval"></span></label>
  <label><input type="checkbox" id="colour" checked> colour by |u|</label>
  <label><input type="checkbox" id="undeformed" checked> undeformed</label>
  <span id="err"></span>
</div>
<canvas id="view"></canvas>
<div id="help">drag: rotate &middot; shift-drag or right button: pan &middot; wheel: zoom
  &middot; double-click: reset &middot; red dashed: rigid elements &middot; orange: springs
  &middot; black squares: masses</div>
<script type="application/json" id="femcal-data">@DATA@</script>
<script>
@SCRIPT@
</script>
</body>
</html>
"""

_SCRIPT = r"""
(function () {
  "use strict";
  var root = document.documentElement;
  function fail(msg) {
    root.setAttribute("data-femcal", "error: " + msg);
    var el = document.getElementById("err");
    if (el) { el.textContent = "error: " + msg; }
  }
  window.addEventListener("error", function (ev) { fail(ev.message || "script error"); });

  function bytes(s) {
    var bin = atob(s), n = bin.length, u = new Uint8Array(n);
    for (var i = 0; i < n; i++) { u[i] = bin.charCodeAt(i); }
    return u.buffer;
  }
  var D = JSON.parse(document.getElementById("femcal-data").textContent);
  var NP = D.n_points, NE = D.n_edges, NK = D.n_markers, NM = D.n_modes;
  var P = new Float32Array(bytes(D.points));
  var E = new Uint32Array(bytes(D.edges));
  var EK = new Uint8Array(bytes(D.edge_kind));
  var MK = new Uint32Array(bytes(D.markers));
  var MKK = new Uint8Array(bytes(D.marker_kind));
  var S = new Float32Array(bytes(D.shapes));
  if (P.length !== 3 * NP || E.length !== 2 * NE || EK.length !== NE || MK.length !== NK ||
      MKK.length !== NK || S.length !== 3 * NP * NM) {
    throw new Error("the page's data do not have the sizes it states");
  }
  var C = D.center, SIZE = D.size, PERIOD = 2000;

  var testing = /selftest/.test(location.hash);
  var canvas = document.getElementById("view");
  var ctx = canvas.getContext("2d", testing ? { willReadFrequently: true } : {});
  var sel = document.getElementById("mode"), anim = document.getElementById("anim");
  var scale = document.getElementById("scale"), scaleval = document.getElementById("scaleval");
  var colour = document.getElementById("colour"), undef = document.getElementById("undeformed");
  document.getElementById("name").textContent = D.title || "";
  for (var m = 0; m < NM; m++) {
    var o = document.createElement("option");
    o.value = String(m);
    o.textContent = D.modes[m].mode + ": " + D.modes[m].frequency_hz.toFixed(3) + " Hz";
    sel.appendChild(o);
  }

  /* magnitudes of each mode's unit shape, made when first shown */
  var MAG = [];
  function magnitudes(m) {
    if (!MAG[m]) {
      var a = new Float32Array(NP), off = 3 * NP * m;
      for (var i = 0; i < NP; i++) {
        var x = S[off + 3 * i], y = S[off + 3 * i + 1], z = S[off + 3 * i + 2];
        a[i] = Math.sqrt(x * x + y * y + z * z);
      }
      MAG[m] = a;
    }
    return MAG[m];
  }

  /* viridis, 16 steps */
  var VIR = [[68, 1, 84], [72, 26, 108], [71, 47, 125], [65, 68, 135], [57, 86, 140],
    [49, 104, 142], [42, 120, 142], [35, 137, 142], [31, 154, 138], [34, 170, 130],
    [53, 183, 121], [84, 197, 104], [122, 209, 81], [165, 219, 54], [210, 226, 27],
    [253, 231, 37]];
  var NB = VIR.length;
  var VIRS = VIR.map(function (c) { return "rgb(" + c.join(",") + ")"; });

  /* view: R rows are the screen's x (right), y (up) and z (towards the eye) in basic */
  function iso() {
    var d = norm([1, 1, 1]), up = [0, 0, 1], r = norm(cross(up, d));
    return [r, cross(d, r), d];
  }
  function norm(v) {
    var l = Math.hypot(v[0], v[1], v[2]) || 1;
    return [v[0] / l, v[1] / l, v[2] / l];
  }
  function cross(a, b) {
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  }
  function mix(a, b, p, q) {
    return [p * a[0] + q * b[0], p * a[1] + q * b[1], p * a[2] + q * b[2]];
  }
  function turn(R, ax, ang) {
    /* turn the model about the screen's x (ax 0: its front goes down for ang > 0) or y axis
       (ax 1: its front goes right) */
    var c = Math.cos(ang), s = Math.sin(ang);
    if (ax === 1) { return [mix(R[0], R[2], c, s), R[1], mix(R[0], R[2], -s, c)]; }
    return [R[0], mix(R[1], R[2], c, -s), mix(R[1], R[2], s, c)];
  }
  var view = { R: iso(), zoom: 1, px: 0, py: 0 };
  function reset() { view.R = iso(); view.zoom = 1; view.px = 0; view.py = 0; }

  var X = new Float32Array(NP), Y = new Float32Array(NP);
  var X0 = new Float32Array(NP), Y0 = new Float32Array(NP);
  var W = 0, H = 0, DPR = 1, t0 = null, phase = 1, last = { ink: 0, shift: 0 };

  function project(amp, m, XX, YY) {
    var R = view.R, off = 3 * NP * m;
    var k = view.zoom * 0.8 * Math.min(W, H - 40) / SIZE;
    var cx = W / 2 + view.px, cy = H / 2 + 20 + view.py;
    for (var i = 0; i < NP; i++) {
      var x = P[3 * i] - C[0], y = P[3 * i + 1] - C[1], z = P[3 * i + 2] - C[2];
      if (amp !== 0) {
        x += amp * S[off + 3 * i]; y += amp * S[off + 3 * i + 1]; z += amp * S[off + 3 * i + 2];
      }
      XX[i] = cx + k * (R[0][0] * x + R[0][1] * y + R[0][2] * z);
      YY[i] = cy - k * (R[1][0] * x + R[1][1] * y + R[1][2] * z);
    }
  }
  function strokeEdges(XX, YY, kind, style, width, dash) {
    ctx.beginPath();
    var n = 0;
    for (var e = 0; e < NE; e++) {
      if (EK[e] !== kind) { continue; }
      var a = E[2 * e], b = E[2 * e + 1];
      ctx.moveTo(XX[a], YY[a]); ctx.lineTo(XX[b], YY[b]); n++;
    }
    if (!n) { return; }
    ctx.strokeStyle = style; ctx.lineWidth = width; ctx.setLineDash(dash || []);
    ctx.stroke(); ctx.setLineDash([]);
  }

  function size() {
    var w = canvas.clientWidth, h = canvas.clientHeight, d = window.devicePixelRatio || 1;
    if (w !== W || h !== H || d !== DPR) {
      W = w; H = h; DPR = d;
      canvas.width = Math.max(1, Math.round(w * d)); canvas.height = Math.max(1, Math.round(h * d));
    }
  }

  function draw() {
    size();
    var m = Number(sel.value) || 0, frac = Number(scale.value);
    var amp = NM ? frac * SIZE * phase : 0, thick = NE > 5000 ? 1 : 2;
    scaleval.textContent = frac.toFixed(3);
    ctx.setTransform(DPR, 0, 0, DPR, 0, 0);
    ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, W, H);
    ctx.lineCap = "round";
    project(0, m, X0, Y0);
    project(amp, m, X, Y);
    if (undef.checked) {
      ctx.globalAlpha = 0.35;
      for (var kk = 0; kk < 3; kk++) { strokeEdges(X0, Y0, kk, "#888", 1); }
      ctx.globalAlpha = 1;
    }
    if (colour.checked) {
      var mag = NM ? magnitudes(m) : new Float32Array(NP), f = Math.abs(phase), bins = [];
      for (var b = 0; b < NB; b++) { bins.push([]); }
      for (var e = 0; e < NE; e++) {
        if (EK[e] !== 0) { continue; }
        var v = 0.5 * (mag[E[2 * e]] + mag[E[2 * e + 1]]) * f;
        bins[Math.min(NB - 1, Math.floor(v * NB))].push(e);
      }
      ctx.lineWidth = thick;
      for (var bb = 0; bb < NB; bb++) {
        var list = bins[bb];
        if (!list.length) { continue; }
        ctx.beginPath();
        for (var q = 0; q < list.length; q++) {
          var a = E[2 * list[q]], c = E[2 * list[q] + 1];
          ctx.moveTo(X[a], Y[a]); ctx.lineTo(X[c], Y[c]);
        }
        ctx.strokeStyle = VIRS[bb]; ctx.stroke();
      }
      legend();
    } else {
      strokeEdges(X, Y, 0, "#1f4e9c", thick);
    }
    strokeEdges(X, Y, 1, "#d62728", 1.5, [5, 3]);
    strokeEdges(X, Y, 2, "#ff7f0e", 2.5);
    for (var i = 0; i < NK; i++) {
      var p = MK[i];
      ctx.fillStyle = MKK[i] === 0 ? "#000" : "#ff7f0e";
      ctx.fillRect(X[p] - 3.5, Y[p] - 3.5, 7, 7);
    }
    var shift = 0;
    for (var j = 0; j < NP; j++) {
      shift = Math.max(shift, Math.abs(X[j] - X0[j]) + Math.abs(Y[j] - Y0[j]));
    }
    last.shift = shift;
    root.setAttribute("data-femcal-mode", String(m + 1));
  }

  function legend() {
    var w = 160, h = 10, x = W - w - 20, y = H - 34;
    for (var b = 0; b < NB; b++) {
      ctx.fillStyle = VIRS[b]; ctx.fillRect(x + b * w / NB, y, w / NB + 1, h);
    }
    ctx.fillStyle = "#333"; ctx.font = "12px system-ui, sans-serif"; ctx.textAlign = "left";
    ctx.fillText("0", x, y + h + 13);
    ctx.textAlign = "right"; ctx.fillText("|u| / max  1", x + w, y + h + 13);
  }

  function ink() {
    var img = ctx.getImageData(0, 0, canvas.width, canvas.height).data, n = 0;
    for (var i = 0; i < img.length; i += 4) { if (img[i] + img[i + 1] + img[i + 2] < 600) { n++; } }
    return n;
  }

  var raf = 0;
  function frame(ts) {
    raf = 0;
    if (!anim.checked) { phase = 1; draw(); return; }
    if (t0 === null) { t0 = ts; }
    phase = Math.sin(2 * Math.PI * ((ts - t0) % PERIOD) / PERIOD);
    draw();
    raf = window.requestAnimationFrame(frame);
  }
  function redraw() {
    if (anim.checked) {
      if (!raf) { raf = window.requestAnimationFrame(frame); }
    } else { phase = 1; draw(); }
  }

  var drag = null;
  canvas.addEventListener("pointerdown", function (ev) {
    drag = { x: ev.clientX, y: ev.clientY, pan: ev.shiftKey || ev.button === 2 || ev.button === 1 };
    try { canvas.setPointerCapture(ev.pointerId); } catch (err) { /* a synthetic pointer */ }
    canvas.style.cursor = "grabbing";
  });
  canvas.addEventListener("pointermove", function (ev) {
    if (!drag) { return; }
    var dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
    drag.x = ev.clientX; drag.y = ev.clientY;
    if (drag.pan) { view.px += dx; view.py += dy; } else {
      view.R = turn(turn(view.R, 1, dx * 0.01), 0, dy * 0.01);
    }
    redraw();
  });
  function up() { drag = null; canvas.style.cursor = "grab"; }
  canvas.addEventListener("pointerup", up);
  canvas.addEventListener("pointercancel", up);
  canvas.addEventListener("contextmenu", function (ev) { ev.preventDefault(); });
  canvas.addEventListener("wheel", function (ev) {
    ev.preventDefault();
    view.zoom = Math.min(200, Math.max(0.05, view.zoom * Math.exp(-ev.deltaY * 0.0015)));
    redraw();
  }, { passive: false });
  canvas.addEventListener("dblclick", function () { reset(); redraw(); });
  [sel, scale, colour, undef].forEach(function (el) {
    el.addEventListener("input", redraw); el.addEventListener("change", redraw);
  });
  anim.addEventListener("change", function () { t0 = null; redraw(); });
  window.addEventListener("resize", redraw);

  function same(a, b) {
    for (var i = 0; i < 3; i++) {
      for (var j = 0; j < 3; j++) { if (Math.abs(a[i][j] - b[i][j]) > 1e-12) { return false; } }
    }
    return true;
  }
  function selftest() {
    var bad = [], wasAnim = anim.checked;
    anim.checked = false; phase = 1;
    for (var m = 0; m < NM; m++) {
      sel.value = String(m); sel.dispatchEvent(new Event("change"));
      if (ink() < 50) { bad.push("mode " + (m + 1) + " draws nothing"); }
      if (!(last.shift > 1)) { bad.push("mode " + (m + 1) + " does not move the model"); }
    }
    sel.value = "0"; sel.dispatchEvent(new Event("change"));
    var R0 = view.R;
    function pointer(type, x, y) {
      canvas.dispatchEvent(new PointerEvent(type, { clientX: x, clientY: y, button: 0,
        pointerId: 7, bubbles: true }));
    }
    pointer("pointerdown", 200, 200);
    pointer("pointermove", 260, 230);
    pointer("pointerup", 260, 230);
    if (same(R0, view.R)) { bad.push("dragging does not rotate"); }
    var z = view.zoom;
    canvas.dispatchEvent(new WheelEvent("wheel", { deltaY: -300, bubbles: true,
      cancelable: true }));
    if (!(view.zoom > z)) { bad.push("the wheel does not zoom"); }
    canvas.dispatchEvent(new MouseEvent("dblclick", { bubbles: true }));
    if (!same(view.R, iso()) || view.zoom !== 1) { bad.push("double-click does not reset"); }
    scale.value = "0"; scale.dispatchEvent(new Event("input"));
    if (last.shift > 1e-3) { bad.push("scale 0 still deforms"); }
    scale.value = "0.08"; scale.dispatchEvent(new Event("input"));
    colour.checked = false; colour.dispatchEvent(new Event("change"));
    var plain = ink();
    colour.checked = true; colour.dispatchEvent(new Event("change"));
    if (plain < 50) { bad.push("uncoloured drawing is empty"); }
    anim.checked = wasAnim; anim.dispatchEvent(new Event("change"));
    root.setAttribute("data-femcal-selftest", bad.length ? "fail: " + bad.join("; ") : "pass");
  }

  if (/still/.test(location.hash)) { anim.checked = false; }
  phase = anim.checked ? 0.999 : 1;
  draw();
  last.ink = ink();
  root.setAttribute("data-femcal-ink", String(last.ink));
  root.setAttribute("data-femcal-edges", String(NE));
  root.setAttribute("data-femcal-modes", String(NM));
  if (testing) { selftest(); }
  root.setAttribute("data-femcal", "ok");
  redraw();
})();
"""
