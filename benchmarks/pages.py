"""Report pages as a reader's browser lays them out (issue 41): each page opened in headless
Chromium at 1024 px (femcal.viz.pagecheck), a table of what a reader meets: whether it
scrolls sideways, what comes before the verdict and how far down it starts, pictures that did
not load. A screenshot of each first screen is written beside the table.

    make bench-pages                       # the demo's pages: out/report.html, ...
    .venv/bin/python benchmarks/pages.py PAGE.html [...] [--width 1024] [--shots DIR]

The tests do the same where Chromium is installed (tests/browser.py); this script is the
check on a machine whose tests skipped it, and the record of the figures in RESULTS.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from femcal.viz.pagecheck import page_layout
from femcal.viz.webview import find_browser

DEFAULT = ["out/report.html", "out/correlation/correlation.html", "out/rig/report.html"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("pages", nargs="*", type=Path)
    ap.add_argument("--width", type=int, default=1024)
    ap.add_argument("--shots", type=Path, default=Path("out/page_shots"))
    args = ap.parse_args()
    if find_browser() is None:
        print("no Chromium-family browser on PATH: apt-get install chromium", file=sys.stderr)
        return 2
    pages = args.pages or [Path(p) for p in DEFAULT if Path(p).is_file()]
    if not pages:
        print("no pages: run make demo first, or name pages", file=sys.stderr)
        return 2
    args.shots.mkdir(parents=True, exist_ok=True)
    print("| page | width (px) | scrolls sideways | before the verdict | verdict top (px) "
          "| broken pictures | screenshot |")
    print("|---|---|---|---|---|---|---|")
    bad = 0
    for page in pages:
        shot = args.shots / (page.parent.name + "_" + page.stem + ".png")
        lay = page_layout(page, width=args.width, screenshot=shot)
        ok = (lay.first_heading == "Verdict" and lay.before_verdict == ("h1",)
              and not lay.scrolls_sideways and not lay.broken_images)
        bad += not ok
        top = "-" if lay.verdict_top is None else f"{lay.verdict_top:.0f}"
        print(f"| {page} | {args.width} | {'yes' if lay.scrolls_sideways else 'no'} "
              f"({lay.scroll_width}) | {' '.join(lay.before_verdict) or '(no verdict)'} | "
              f"{top} | {len(lay.broken_images)} | {shot} |")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
