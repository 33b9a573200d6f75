"""Report pages as a reader's browser shows them (headless Chromium, where installed): the
verdict block is the first thing under the title, within the first screen, and nothing
scrolls sideways at 1024 px; a page's 3-D viewers draw and pass their self-tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from femcal.viz.pagecheck import page_layout
from femcal.viz.webview import browser_check, find_browser

__all__ = ["assert_verdict_first_at_1024", "find_browser", "needs_browser"]

#: Skip where no Chromium-family browser is installed (benchmarks/pages.py says the same
#: where one is).
needs_browser = pytest.mark.skipif(find_browser() is None, reason="no Chromium on PATH")


def assert_verdict_first_at_1024(page: Path, shot: Path) -> None:
    lay = page_layout(page, width=1024, screenshot=shot)
    assert lay.first_heading == "Verdict", lay
    assert lay.before_verdict == ("h1",), lay
    assert lay.verdict_top is not None and lay.verdict_top < 200, lay
    assert not lay.scrolls_sideways and not lay.too_wide, lay
    assert not lay.broken_images, lay
    assert shot.stat().st_size > 10_000  # a screenshot with something in it
    if 'class="femcal-viewer' in page.read_text(encoding="utf-8"):
        r = browser_check(page, window=(1024, 900))
        assert r.ok, r  # every viewer drew, its self-test passed, the console stayed silent
