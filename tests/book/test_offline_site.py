"""The rendered book works opened from disk with no network: math, widgets and animations.

A throwaway one-page book is built in a temporary folder with the repository's own ``_config.yml``
(same vendored-asset settings as ``make book``). Its page has inline math, an ipywidgets slider and
a ``to_jshtml`` animation. The HTML check proves every script and stylesheet is a local file that
exists; where Debian's chromium is installed, a headless render with all network blocked proves
MathJax typesets and the widget manager draws the slider.

Skips (does not fail) where the vendored assets cannot be produced (no npm, or no registry).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import urlparse

import nbformat
import pytest

REPO = Path(__file__).resolve().parents[2]
VENDOR = REPO / "_build" / "vendor"
CHROMIUM = Path("/usr/bin/chromium")

PAGE_CELLS = [
    ("markdown", "# Offline page\n\nInline math $x^2 + \\alpha_t$ and a display:\n\n$$\\int_0^1 t\\,dt = \\tfrac12$$"),
    ("code", "import os\nprofile = os.environ.get('MOTIONLAB_PROFILE', 'smoke')"),
    ("code", "from motionlab import book\nprofile = book.setup(seed=0, profile=profile)"),
    ("code", "import ipywidgets as widgets\nwidgets.IntSlider(value=3, min=0, max=9, description='steps')"),
    (
        "code",
        "import matplotlib.pyplot as plt\nfrom matplotlib.animation import FuncAnimation\n"
        "fig, ax = plt.subplots(figsize=(1.2, 1.2), dpi=40)\n(line,) = ax.plot([0, 1], [0, 0])\n"
        "anim = FuncAnimation(fig, lambda i: line.set_ydata([0, i / 3]) or (line,), frames=3)\n"
        "book.embed_animation(anim)",
    ),
]


def ensure_vendored() -> None:
    sys.path.insert(0, str(REPO / "tools"))
    try:
        import vendor_web_assets as vendor
    finally:
        sys.path.pop(0)
    if vendor.is_current(VENDOR):
        return
    if shutil.which("npm") is None and not (REPO / "node_modules").is_dir():
        pytest.skip("npm is not available, so MathJax/widget assets cannot be vendored")
    proc = subprocess.run(
        [sys.executable, str(REPO / "tools" / "vendor_web_assets.py")],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=240,
    )
    if proc.returncode != 0:
        pytest.skip(f"vendoring failed (npm registry unreachable?): {proc.stderr[-500:]}")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """Build the one-page book with the repository's _config.yml; return the page's path."""
    jb = Path(sys.executable).parent / "jupyter-book"
    if not jb.exists():
        pytest.skip("jupyter-book is not installed (it comes with the book extra)")
    ensure_vendored()
    root = tmp_path_factory.mktemp("offline-book")
    (root / "book").mkdir()
    shutil.copy(REPO / "book" / "references.bib", root / "book" / "references.bib")
    shutil.copytree(REPO / "book" / "_ext", root / "book" / "_ext")  # the site's Sphinx extension (_config.yml)
    (root / "_build").mkdir()
    (root / "_build" / "vendor").symlink_to(VENDOR, target_is_directory=True)  # html_static_path
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_markdown_cell(src) if kind == "markdown" else nbformat.v4.new_code_cell(src)
        for kind, src in PAGE_CELLS
    ]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nbformat.write(nb, root / "page.ipynb")
    (root / "_toc.yml").write_text("format: jb-book\nroot: page\n")

    env = os.environ | {"MOTIONLAB_PROFILE": "smoke", "MOTIONLAB_HOME": str(root / "home")}
    proc = subprocess.run(
        [
            str(jb),
            "build",
            str(root),
            "--config",
            str(REPO / "_config.yml"),
            "--toc",
            str(root / "_toc.yml"),
            "-W",
            "-n",
            "--keep-going",
        ],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return root / "_build" / "html" / "page.html"


class Assets(HTMLParser):
    """Collects script/link URLs and the bodies of typed <script> blocks."""

    def __init__(self) -> None:
        super().__init__()
        self.urls: list[tuple[str, str]] = []
        self.blocks: dict[str, list[str]] = {}
        self._type: str | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "script":
            if a.get("src"):
                self.urls.append(("script", a["src"]))
            self._type = a.get("type")
        elif tag == "link" and a.get("href") and a.get("rel") not in ("index", "search", "next", "prev"):
            self.urls.append(("link", a["href"]))

    def handle_data(self, data):
        if self._type:
            self.blocks.setdefault(self._type, []).append(data)

    def handle_endtag(self, tag):
        if tag == "script":
            self._type = None


def test_page_loads_only_local_assets(site):
    html = site.read_text()
    parser = Assets()
    parser.feed(html)
    assert parser.urls, "no scripts or stylesheets found"
    for kind, url in parser.urls:
        parsed = urlparse(url)
        assert not parsed.scheme and not parsed.netloc, f"{kind} loads from the network: {url}"
        assert (site.parent / parsed.path).is_file(), f"{kind} {url} does not exist in the site"
    scripts = [urlparse(u).path for k, u in parser.urls if k == "script"]
    assert "_static/mathjax/tex-chtml.js" in scripts
    assert "_static/widgets/require.js" in scripts and "_static/widgets/embed-amd.js" in scripts
    # MathJax lazily loads its fonts relative to itself: they must have been copied too.
    assert list((site.parent / "_static" / "mathjax" / "output" / "chtml" / "fonts").rglob("*.woff"))
    assert "\\(x^2 + \\alpha_t\\)" in html  # the TeX is in the page, for MathJax to typeset


def test_widget_state_and_animation_are_embedded(site):
    parser = Assets()
    parser.feed(site.read_text())
    state = json.loads("".join(parser.blocks["application/vnd.jupyter.widget-state+json"]))
    sliders = {k: m for k, m in state["state"].items() if m["model_name"] == "IntSliderModel"}
    assert len(sliders) == 1 and next(iter(sliders.values()))["state"]["value"] == 3
    views = [json.loads(b) for b in parser.blocks["application/vnd.jupyter.widget-view+json"]]
    assert {v["model_id"] for v in views} <= set(state["state"]) and views
    html = site.read_text()
    assert html.count("data:image/png;base64") >= 3  # one embedded PNG per frame
    assert "new Animation(" in html


@pytest.mark.skipif(not CHROMIUM.exists(), reason="/usr/bin/chromium not installed")
def test_headless_render_without_network(site, tmp_path):
    # A dead proxy makes every http(s) request fail; file:// is unaffected.
    cmd = [
        str(CHROMIUM),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--no-first-run",
        f"--user-data-dir={tmp_path / 'profile'}",
        "--proxy-server=127.0.0.1:9",
        "--proxy-bypass-list=<-loopback>",
        "--virtual-time-budget=15000",
        "--dump-dom",
        site.as_uri(),
    ]
    dom = subprocess.run(cmd, capture_output=True, text=True, timeout=90).stdout
    assert "<mjx-container" in dom, "MathJax did not typeset the page"
    assert "\\(x^2" not in dom, "raw TeX left in the rendered page"
    assert "widget-slider" in dom and "noUi-target" in dom, "the widget manager did not draw the slider"
    assert 'id="_anim_img' in dom and 'src="data:image/png;base64' in dom
