"""The built site in a real browser: every page as a reader opens it from disk, with no network.

Reads the site ``make book`` rendered (``_build/html``; ``MOTIONLAB_SITE`` points elsewhere) and opens every page
of the book in headless Chromium at 1300×1000 from ``file://``, every http(s) request sent to a dead proxy. Each page
must log no console error (a script error, a missing file), send no request off the machine, typeset all its math
with MathJax and render every saved widget view; its text must carry no absolute path of this machine and no Python
warning; and no table, code cell or printed output may scroll sideways, no figure be shrunk to fit the column. Skips
where no site was built (``make book PROFILE=smoke`` builds one) or no browser is installed (see ``conftest.py``).
"""

from __future__ import annotations

import json
import os
import re
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SITE = Path(os.environ.get("MOTIONLAB_SITE", REPO / "_build" / "html")).resolve()
# chrome-untrusted: is Chromium's own new-tab page, which a fresh browser may still be loading when the first page opens
LOCAL_SCHEMES = ("file:", "data:", "blob:", "about:", "chrome:", "chrome-error:", "chrome-untrusted:", "devtools:")

pytestmark = pytest.mark.browser


def book_pages(site: Path) -> list[Path]:
    """The pages a reader reaches: every HTML file of the site but Sphinx's own assets and sources."""
    skip = {"_static", "_sources", "_images", "_downloads"}
    return sorted(p for p in site.rglob("*.html") if not skip & set(p.relative_to(site).parts))


@pytest.fixture(scope="module")
def site() -> Path:
    if not (SITE / "index.html").is_file():
        pytest.skip(f"no built site at {SITE}: run `make book PROFILE=smoke` first")
    return SITE


@pytest.fixture(scope="module")
def browser(browser_factory):
    return browser_factory(offline=True)


# Runs in the page: waits for MathJax and the widget manager to finish, then reports what a reader would see.
SETTLE_JS = """
const done = arguments[arguments.length - 1];
const start = Date.now();
function views() {
  const scripts = [...document.querySelectorAll('script[type="application/vnd.jupyter.widget-view+json"]')];
  return scripts.map(s => {
    // the html-manager draws each view into an element it inserts just before the view's script
    const host = s.previousElementSibling;
    const drawn = host && host.classList.contains('widget-subarea') && host.querySelector('.jupyter-widgets');
    return {model: JSON.parse(s.textContent).model_id, drawn: !!drawn,
            error: !!(host && /Error displaying widget/.test(host.textContent))};
  });
}
function math() {
  const nodes = [...document.querySelectorAll('.math')];
  return {total: nodes.length, typeset: nodes.filter(n => n.querySelector('mjx-container') ||
                                                    n.tagName === 'MJX-CONTAINER').length};
}
function layout() {
  // what scrolls sideways at this width (tables, code, printed output), and figures shrunk to fit the column
  const wide = [...document.querySelectorAll('article .cell_output .pst-scrollable-table-container, ' +
                                             'article .cell_output .table-wrapper, article div.cell pre')]
    .filter(e => e.scrollWidth > e.clientWidth + 2)
    .map(e => (e.closest('.cell_input') ? 'code: ' : 'output: ') + e.innerText.slice(0, 60));
  const shrunk = [...document.querySelectorAll('article .cell_output img')]
    .filter(i => i.clientWidth > 0 && i.naturalWidth > 1.1 * i.clientWidth)
    .map(i => Math.round(100 * i.clientWidth / i.naturalWidth) + '% of ' + i.naturalWidth + ' px');
  // anything else that scrolls sideways inside the article (display math, an admonition, a scrollable wrapper)
  const scrolling = [...document.querySelectorAll('article *')]
    .filter(e => ['auto', 'scroll'].includes(getComputedStyle(e).overflowX) && e.scrollWidth > e.clientWidth + 2)
    .filter(e => !wide.length || !e.closest('div.cell'))
    .map(e => e.tagName.toLowerCase() + '.' + [...e.classList].join('.') + ': ' + e.innerText.slice(0, 60));
  return {wide: [...new Set([...wide, ...scrolling])], shrunk: shrunk};
}
function lesson() {
  // where the first figure and the verdicts sit, which figures lack a caption, which exercises lack an answer
  const top = e => e.getBoundingClientRect().top + window.scrollY;
  const images = [...document.querySelectorAll('article .cell_output img, article figure img')]
    .filter(i => !i.closest('.animation') && i.clientHeight > 0);
  // a figure's caption is its <figcaption>; a "Try it" (book.try_it) carries its caption under its output
  const captioned = i => (i.closest('figure') && i.closest('figure').querySelector('figcaption')) ||
                         (i.closest('.ml-try-it') && i.closest('.ml-try-it').querySelector('.ml-caption'));
  const uncaptioned = images.filter(i => !captioned(i))
    .map(i => i.alt.slice(0, 40) || i.src.slice(-40));
  const findings = document.querySelector('article .ml-findings');
  const exercises = [...document.querySelectorAll('article .admonition')]
    .filter(a => /^Exercise/.test((a.querySelector('.admonition-title') || {}).textContent || ''));
  const unanswered = exercises.filter(a => {
    for (let e = a.nextElementSibling; e; e = e.nextElementSibling) {
      if (exercises.includes(e) || /^H[1-6]$/.test(e.tagName)) break;
      const summary = e.querySelector('summary');
      if (summary && summary.textContent.trim().startsWith('Answer')) return false;
    }
    return true;
  }).map(a => a.querySelector('.admonition-title').textContent.slice(0, 50));
  return {firstFigure: images.length ? Math.min(...images.map(top)) : null, figures: images.length,
          uncaptioned: uncaptioned, findings: findings ? top(findings) : null, exercises: exercises.length,
          unanswered: unanswered};
}
function poll() {
  const v = views(), m = math();
  const mathReady = !window.MathJax || !MathJax.startup || MathJax.startup.document?.state?.() >= 200 ||
                    m.typeset === m.total;
  const settled = v.every(x => x.drawn || x.error) && m.typeset === m.total && document.readyState === 'complete';
  if ((settled && mathReady) || Date.now() - start > 30000) {
    done({views: v, math: m, text: document.body.innerText, height: document.documentElement.scrollHeight,
          layout: layout(), lesson: lesson(),
          resources: performance.getEntriesByType('resource').map(r => r.name)});
  } else {
    setTimeout(poll, 200);
  }
}
poll();
"""


def network_requests(driver) -> list[str]:
    """Every URL the page asked for since the last call (from the DevTools performance log)."""
    urls = []
    for entry in driver.get_log("performance"):
        message = json.loads(entry["message"])["message"]
        if message.get("method") == "Network.requestWillBeSent":
            urls.append(message["params"]["request"]["url"])
    return urls


def open_page(driver, page: Path) -> dict:
    driver.get_log("browser")  # drop what earlier pages logged
    network_requests(driver)
    driver.get(page.as_uri())
    report = driver.execute_async_script(SETTLE_JS)
    time.sleep(0.5)  # late font and image loads report their failures asynchronously
    report["console"] = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    report["requests"] = network_requests(driver) + report.pop("resources")
    return report


def machine_paths() -> list[str]:
    """Absolute paths of this machine that must never appear in a rendered output."""
    from motionlab.paths import cache_dir

    paths = {str(REPO), str(Path.home()), str(cache_dir())}
    return sorted(p for p in paths if len(p) > 1)


@pytest.fixture(scope="module")
def reports(site, browser) -> dict[str, dict]:
    pages = book_pages(site)
    assert pages, f"no pages found under {site}"
    return {str(p.relative_to(site)): open_page(browser, p) for p in pages}


def test_every_page_logs_no_console_error(reports):
    errors = {page: [e["message"] for e in r["console"]] for page, r in reports.items() if r["console"]}
    assert not errors, "console errors:\n" + "\n".join(f"{p}: {m}" for p, ms in errors.items() for m in ms)


def test_no_request_leaves_the_machine(reports):
    remote = {
        page: sorted({u for u in r["requests"] if not u.startswith(LOCAL_SCHEMES)}) for page, r in reports.items()
    }
    remote = {page: urls for page, urls in remote.items() if urls}
    assert not remote, f"pages that reach the network: {remote}"


def test_every_saved_widget_view_renders(reports):
    chapters = {page: r["views"] for page, r in reports.items() if page.startswith("notebooks/")}
    assert any(chapters.values()), "no chapter carries a saved widget view: was the widget state stored?"
    broken = {page: [v["model"] for v in views if not v["drawn"] or v["error"]] for page, views in chapters.items()}
    broken = {page: models for page, models in broken.items() if models}
    assert not broken, f"widget views that did not render: {broken}"


def test_mathjax_typesets_every_formula(reports):
    assert sum(r["math"]["total"] for r in reports.values()) > 0, "no math found in the book"
    raw = {page: r["math"] for page, r in reports.items() if r["math"]["typeset"] < r["math"]["total"]}
    assert not raw, f"formulas left as raw TeX: {raw}"


def test_outputs_carry_no_machine_path_and_no_warning(reports):
    paths = machine_paths()
    leaks = {page: [p for p in paths if p in r["text"]] for page, r in reports.items()}
    leaks = {page: found for page, found in leaks.items() if found}
    assert not leaks, f"absolute paths of this machine in the rendered pages: {leaks}"
    warning = re.compile(r"\b\w*Warning: ")
    warned = {page: warning.findall(r["text"]) for page, r in reports.items() if warning.search(r["text"])}
    assert not warned, f"Python warnings in the rendered outputs: {warned}"


def test_nothing_scrolls_sideways_and_figures_keep_their_size(reports):
    wide = {page: r["layout"]["wide"] for page, r in reports.items() if r["layout"]["wide"]}
    assert not wide, f"wider than the content column at 1300 px: {wide}"
    shrunk = {page: r["layout"]["shrunk"] for page, r in reports.items() if r["layout"]["shrunk"]}
    assert not shrunk, f"figures scaled down to fit the column (their labels shrink with them): {shrunk}"


def chapters(reports: dict[str, dict]) -> dict[str, dict]:
    """The teaching chapters 01-09, by page."""
    return {page: r for page, r in reports.items() if re.match(r"notebooks/0\d_", page)}


def test_a_chapter_opens_with_a_picture_and_ends_with_its_verdicts(reports):
    pages = chapters(reports)
    assert pages, "no chapter pages in the site"
    late = {p: r["lesson"]["firstFigure"] for p, r in pages.items() if (r["lesson"]["firstFigure"] or 1e9) > 2000}
    assert not late, f"chapters whose first figure starts below 2,000 px (px from the top): {late}"
    early = {
        p: f"{r['lesson']['findings'] / r['height']:.0%} of {r['height']} px"
        for p, r in pages.items()
        if r["lesson"]["findings"] is not None and r["lesson"]["findings"] < 0.6 * r["height"]
    }
    assert not early, f"chapters whose verdicts come before 60% of the page: {early}"


def test_every_figure_has_a_caption(reports):
    bare = {p: r["lesson"]["uncaptioned"] for p, r in chapters(reports).items() if r["lesson"]["uncaptioned"]}
    assert not bare, f"figures without a caption: {bare}"


def test_every_exercise_has_an_answer(reports):
    assert sum(r["lesson"]["exercises"] for r in reports.values()) > 0, "no exercise found in the book"
    open_ = {p: r["lesson"]["unanswered"] for p, r in reports.items() if r["lesson"]["unanswered"]}
    assert not open_, f"exercises without a folded answer: {open_}"


# Which "Try it" panels show what: the visible output of each, by position on the page.
TRY_IT_STATE_JS = """
return [...document.querySelectorAll('article .ml-try-it')].map(w => {
  const shown = [...w.querySelectorAll('img, p, table')].filter(e => e.offsetParent !== null);
  // a short fingerprint of what is visible: images of one size can share their last bytes, so hash them all
  const text = shown.map(e => e.src || e.innerText).join('|');
  let hash = 0;
  for (let i = 0; i < text.length; i++) hash = (hash * 31 + text.charCodeAt(i)) | 0;
  return text.length + ':' + hash;
});
"""
TRY_IT_CHAPTERS = ("03", "05", "07", "08", "09")  # at least one "Try it" each that answers without a kernel


def test_a_try_it_slider_changes_what_the_page_shows(site, browser):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    moved = {}
    for page in book_pages(site):
        name = str(page.relative_to(site))
        if not re.match(rf"notebooks/({'|'.join(TRY_IT_CHAPTERS)})_", name):
            continue
        open_page(browser, page)
        before = browser.execute_script(TRY_IT_STATE_JS)
        handles = browser.find_elements(By.CSS_SELECTOR, "article .ml-try-it .noUi-handle")
        for handle in handles:
            browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", handle)
            handle.click()
            handle.send_keys(Keys.ARROW_RIGHT)  # one step along the precomputed values
        time.sleep(0.5)
        after = browser.execute_script(TRY_IT_STATE_JS)
        moved[name] = (len(handles), sum(a != b for a, b in zip(before, after)), len(before))
    assert len(moved) == len(TRY_IT_CHAPTERS), f"chapters with a Try it: {sorted(moved)}"
    frozen = {page: counts for page, counts in moved.items() if counts[1] == 0}
    assert not frozen, f"pages where moving every slider changed no Try it (sliders, changed, widgets): {frozen}"


# A page's weight: its HTML with the players' frames and the "Try it" outputs inline (figures are separate files).
# Measured on the laptop site at commit 070b657: at most 4.8 MB (09, its players and T_s × N_a Try it).
PAGE_BUDGET_BYTES = 6_000_000


def test_every_page_stays_within_its_size_budget(site):
    heavy = {
        str(p.relative_to(site)): p.stat().st_size for p in book_pages(site) if p.stat().st_size > PAGE_BUDGET_BYTES
    }
    assert not heavy, f"pages over {PAGE_BUDGET_BYTES:,} bytes: {heavy}"


def test_the_checks_see_a_planted_fault(browser, tmp_path):
    """A page with a script error, a missing file and a request to the network: each check must report it."""
    page = tmp_path / "planted.html"
    page.write_text(
        "<!DOCTYPE html><html><body><p>planted</p><script>throw new Error('planted fault');</script>"
        '<img src="missing.png"><img src="https://example.org/remote.png"></body></html>'
    )
    report = open_page(browser, page)
    console = " ".join(e["message"] for e in report["console"])
    assert "planted fault" in console and "missing.png" in console, console
    assert any(u.startswith("https://example.org/") for u in report["requests"]), report["requests"]
