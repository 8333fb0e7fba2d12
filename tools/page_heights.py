"""Measure how a reader meets the built site: each page's height, and what scrolls sideways, at 1300 px.

Opens every page of a built site (default ``_build/html``) in headless Chromium (Debian's ``chromium`` and
``chromium-driver``, driven by Selenium) from ``file://`` and prints one line per page: its height in px, the number
of code cells shown and folded, and the elements wider than the content column (tables, code, figures scaled down).
``--sections`` adds each section's height under its page (where a long page spends its screens); ``--json FILE``
writes the same numbers. Usage::

    python tools/page_heights.py [SITE] [--width 1300] [--sections] [--json heights.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

MEASURE_JS = r"""
const done = arguments[arguments.length - 1];
function measure() {
  const article = document.querySelector('article.bd-article') || document.body;
  const width = article.clientWidth;
  const wide = [];
  for (const el of article.querySelectorAll('.cell_output img')) {
    if (el.clientWidth > 0 && el.naturalWidth > 1.15 * el.clientWidth)
      wide.push({what: 'image scaled to ' + Math.round(100 * el.clientWidth / el.naturalWidth) + '%'});
  }
  for (const el of article.querySelectorAll('*')) {  // whatever scrolls sideways
    const style = getComputedStyle(el);
    if (['auto', 'scroll'].includes(style.overflowX) && el.scrollWidth > el.clientWidth + 2) {
      const kind = el.closest('.cell_input') ? 'code' : el.querySelector('table') ? 'table' :
                   el.closest('.cell_output') ? 'output' : el.tagName.toLowerCase();
      wide.push({what: kind, by: el.scrollWidth - el.clientWidth});
    }
  }
  const cells = [...article.querySelectorAll('.cell')];
  const folded = cells.filter(c => c.classList.contains('tag_hide-input')).length;
  const shown = cells.filter(c => c.querySelector('.cell_input') && !c.classList.contains('tag_hide-input')).length;
  const sections = [...article.querySelectorAll('h1, h2, h3')].map(h => ({
    level: Number(h.tagName[1]), title: h.textContent.replace(/[#¶]\s*$/, '').trim(),
    top: Math.round(h.getBoundingClientRect().top + window.scrollY)}));
  done({height: document.documentElement.scrollHeight, column: width, shown: shown, folded: folded, wide: wide,
        sections: sections});
}
setTimeout(measure, 1500);
"""


def pages(site: Path) -> list[Path]:
    skip = {"_static", "_sources", "_images", "_downloads"}
    return sorted(
        p
        for p in site.rglob("*.html")
        if not skip & set(p.relative_to(site).parts) and p.name not in {"genindex.html", "search.html", "index.html"}
    )


def measure(site: Path, width: int = 1300) -> dict[str, dict]:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = "/usr/bin/chromium"
    with tempfile.TemporaryDirectory() as profile:
        for arg in (
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            f"--user-data-dir={profile}",
            f"--window-size={width},1000",
            "--proxy-server=127.0.0.1:9",
        ):
            opts.add_argument(arg)
        driver = webdriver.Chrome(service=Service(executable_path="/usr/bin/chromedriver"), options=opts)
        driver.set_script_timeout(60)
        try:
            out = {}
            for page in pages(site):
                driver.get(page.as_uri())
                out[str(page.relative_to(site))] = driver.execute_async_script(MEASURE_JS)
            return out
        finally:
            driver.quit()


def section_heights(page: dict) -> list[tuple[dict, int]]:
    """Each heading of a measured page with the height from it to the next heading of its level or above."""
    sections, out = page.get("sections", []), []
    for i, section in enumerate(sections):
        following = (s["top"] for s in sections[i + 1 :] if s["level"] <= section["level"])
        out.append((section, next(following, page["height"]) - section["top"]))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("site", nargs="?", type=Path, default=ROOT / "_build" / "html")
    parser.add_argument("--width", type=int, default=1300)
    parser.add_argument("--sections", action="store_true", help="also print each section's height")
    parser.add_argument("--json", type=Path, help="also write the measurements to this file")
    args = parser.parse_args(argv)
    if not (args.site / "index.html").is_file():
        sys.exit(f"page_heights: no built site at {args.site} (make book PROFILE=smoke)")
    result = measure(args.site, args.width)
    for page, m in result.items():
        wide = ", ".join(f"{w['what']}" + (f" +{w['by']}px" if "by" in w else "") for w in m["wide"]) or "-"
        print(
            f"{page:42s} {m['height']:7,d} px  column {m['column']} px  code shown {m['shown']:2d}, "
            f"folded {m['folded']:2d}  wide: {wide}"
        )
        if args.sections:
            for section, height in section_heights(m):
                print(f"    {'  ' * (section['level'] - 1)}{height:7,d} px  {section['title'][:70]}")
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
