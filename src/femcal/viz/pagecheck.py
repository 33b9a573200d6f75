"""A report page as a reader's browser lays it out: headless Chromium opens a copy of the page
with a small script added, at a given window width, and the script records what a reader
would meet: whether the page scrolls sideways, what comes before the verdict block and how
far down it starts, and the pictures that did not load. Optionally a screenshot is taken.
The page itself is not changed."""

from __future__ import annotations

import html
import json
import tempfile
from dataclasses import dataclass
from pathlib import Path

from .webview import _run_browser, find_browser

_PROBE = """<script>
window.addEventListener('load', function () {
  var d = document.documentElement, v = document.getElementById('verdict');
  var before = [];
  if (v) {
    for (var e = document.body.firstElementChild; e && e !== v; e = e.nextElementSibling) {
      if (e.tagName !== 'SCRIPT') before.push(e.tagName.toLowerCase());
    }
  }
  var broken = [];
  Array.prototype.forEach.call(document.images, function (im) {
    if (!(im.complete && im.naturalWidth > 0)) broken.push(im.alt || im.src.slice(0, 40));
  });
  var wide = [];
  Array.prototype.forEach.call(document.body.querySelectorAll('*'), function (e) {
    var r = e.getBoundingClientRect();
    if (r.right > window.innerWidth + 1 && getComputedStyle(e).position !== 'fixed') {
      var p = e.parentElement, clipped = false;
      for (; p && p !== document.body; p = p.parentElement) {
        if (getComputedStyle(p).overflowX !== 'visible') { clipped = true; break; }
      }
      if (!clipped && wide.length < 5) wide.push(e.tagName.toLowerCase());
    }
  });
  document.body.setAttribute('data-layout', JSON.stringify({
    scroll_width: d.scrollWidth, window_width: window.innerWidth,
    verdict_top: v ? v.getBoundingClientRect().top + window.scrollY : null,
    before_verdict: before, broken_images: broken, too_wide: wide,
    first_heading: (document.querySelector('h2') || {}).textContent || null}));
});
</script>"""


@dataclass(frozen=True)
class Layout:
    """What the browser made of a page at ``window_width`` pixels.

    scroll_width : the document's width (px); above ``window_width`` it scrolls sideways.
    verdict_top : where the verdict block starts (px from the top), None without one.
    before_verdict : the tags of the body's elements before it (``['h1']`` on a good page).
    broken_images : pictures that did not load. too_wide : elements past the window's right
        edge that no scrolling box holds.
    first_heading : the text of the page's first ``h2``.
    screenshot : the PNG taken, if asked.
    """

    scroll_width: int
    window_width: int
    verdict_top: float | None
    before_verdict: tuple[str, ...]
    broken_images: tuple[str, ...]
    too_wide: tuple[str, ...]
    first_heading: str | None
    screenshot: Path | None = None

    @property
    def scrolls_sideways(self) -> bool:
        return self.scroll_width > self.window_width


def page_layout(page: str | Path, *, width: int = 1024, height: int = 900,
                screenshot: str | Path | None = None, browser: str | None = None,
                timeout: float = 120.0) -> Layout:  # fmt: skip
    """Lay ``page`` out in headless Chromium at ``width`` x ``height`` pixels (see the module
    docstring); with ``screenshot``, a PNG of the page's first screen there.

    Raises
    ------
    RuntimeError
        Without a Chromium-family browser, or when it records nothing.
    """
    browser = browser or find_browser()
    if browser is None:
        raise RuntimeError("no Chromium-family browser on PATH (apt-get install chromium)")
    text = Path(page).read_text(encoding="utf-8")
    at = text.rfind("</body>")
    probed = (text[:at] + _PROBE + text[at:]) if at >= 0 else text + _PROBE
    with tempfile.TemporaryDirectory(prefix="femcal-page-") as tmp:
        copy = Path(tmp) / Path(page).name
        copy.write_text(probed, encoding="utf-8")
        size = f"--window-size={width},{height}"
        dom, err = _run_browser(browser, [size, "--virtual-time-budget=5000", "--dump-dom",
                                          copy.as_uri()], timeout)  # fmt: skip
        shot = None
        if screenshot is not None:
            shot = Path(screenshot)
            _run_browser(browser, [size, f"--screenshot={shot}", Path(page).resolve().as_uri()],
                         timeout)  # fmt: skip
    start = dom.find("data-layout=")
    if start < 0:
        raise RuntimeError(f"{browser} recorded nothing for {page}: {err.strip()[-300:]}")
    quote = dom[start + len("data-layout=")]
    end = dom.index(quote, start + len("data-layout=") + 1)
    facts = json.loads(html.unescape(dom[start + len("data-layout=") + 1:end]))
    return Layout(int(facts["scroll_width"]), int(facts["window_width"]), facts["verdict_top"],
                  tuple(facts["before_verdict"]), tuple(facts["broken_images"]),
                  tuple(facts["too_wide"]), facts["first_heading"], shot)  # fmt: skip
