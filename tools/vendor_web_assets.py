"""Vendor the browser assets that make the rendered book work offline.

A Jupyter Book 1 page loads three things from a CDN at view time: MathJax (to typeset math),
require.js and the ipywidgets ``embed-amd.js`` (to render saved widget state). Opened from disk with
no network, math stays raw TeX and widget areas stay blank. This script installs exact versions of
those packages with ``npm ci`` (pinned by the root ``package.json`` / ``package-lock.json``) and copies
the files a page needs into a gitignored folder, by default ``_build/vendor``::

    _build/vendor/widgets/require.js, embed-amd.js, <font files>   -> _static/widgets/...
    _build/vendor/mathjax/tex-chtml.js, input/, output/chtml/, ... -> _static/mathjax/...

``_config.yml`` lists that folder in ``html_static_path`` and points ``mathjax_path`` and
``nb_ipywidgets_js`` at the copies. The folder is *not* the book's ``_static/``: Jupyter Book 1 adds
every ``.js`` file found there to every page, which would load the widget bundle twice.

Idempotent: a stamp file records the hash of the lockfile and of this script; when it matches, the
script does nothing. Usage: ``python tools/vendor_web_assets.py [--dest DIR] [--force]``.
"""

from __future__ import annotations

import argparse
import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DEST = ROOT / "_build" / "vendor"
STAMP_NAME = ".vendor-stamp"

# (package folder under node_modules, files or folders to copy, target folder under dest)
WIDGETS = "@jupyter-widgets/html-manager/dist"
MATHJAX = "mathjax/es5"
# The widget bundle references its icon fonts relative to its own URL, so they travel with it (the page maps that URL
# to _static/widgets/: book/_ext/static/widgets-setup.js). The other
# bundles in dist/ (embed.js for non-AMD pages, libembed-amd.js, a 6 MB source map) are not used.
WIDGET_SKIP = {"embed.js", "embed.js.map", "embed.js.LICENSE.txt", "libembed-amd.js"}
# tex-chtml.js is the single component the book loads; it lazily fetches TeX extensions (input/),
# CHTML fonts (output/chtml/), menu and accessibility parts (ui/, a11y/, sre/) relative to itself.
MATHJAX_PARTS = ("tex-chtml.js", "input", "output/chtml", "output/chtml.js", "ui", "a11y", "sre", "startup.js")


def stamp_value() -> str:
    """Hash of everything that decides the vendored files: the lockfile and this script."""
    digest = hashlib.sha256()
    for path in (ROOT / "package-lock.json", Path(__file__)):
        digest.update(path.read_bytes())
    return digest.hexdigest()


def is_current(dest: Path) -> bool:
    stamp = dest / STAMP_NAME
    return stamp.is_file() and stamp.read_text().strip() == stamp_value()


def npm_install() -> Path:
    """Run ``npm ci`` at the repository root when node_modules lacks a needed package."""
    modules = ROOT / "node_modules"
    needed = [
        modules / WIDGETS / "embed-amd.js",
        modules / MATHJAX / "tex-chtml.js",
        modules / "requirejs" / "require.js",
    ]
    if all(p.exists() for p in needed):
        return modules
    npm = shutil.which("npm")
    if npm is None:
        sys.exit(
            "vendor_web_assets: npm is not on PATH. Install Node.js (>= 18) so that the book's "
            "MathJax and widget renderers can be vendored for offline reading."
        )
    cmd = [npm, "ci", "--no-audit", "--no-fund", "--ignore-scripts", "--loglevel=error"]
    print("vendor_web_assets:", " ".join(cmd[1:]), flush=True)
    subprocess.run(cmd, cwd=ROOT, check=True)
    missing = [str(p) for p in needed if not p.exists()]
    if missing:
        sys.exit(f"vendor_web_assets: npm ci finished but these files are missing: {missing}")
    return modules


def copy_assets(modules: Path, staging: Path) -> None:
    widgets = staging / "widgets"
    widgets.mkdir(parents=True)
    shutil.copy2(modules / "requirejs" / "require.js", widgets / "require.js")
    for item in sorted((modules / WIDGETS).iterdir()):
        if item.is_file() and item.name not in WIDGET_SKIP:
            shutil.copy2(item, widgets / item.name)
    for part in MATHJAX_PARTS:
        src, dst = modules / MATHJAX / part, staging / "mathjax" / part
        dst.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            shutil.copytree(src, dst)
        else:
            shutil.copy2(src, dst)


def vendor(dest: Path = DEFAULT_DEST, force: bool = False) -> Path:
    """Make ``dest`` hold the vendored assets; returns ``dest``."""
    dest = Path(dest)
    if not force and is_current(dest):
        print(f"vendor_web_assets: {dest} is up to date")
        return dest
    modules = npm_install()
    # Build next to the destination, then swap, so an interrupted run never leaves half a folder.
    staging = dest.with_name(dest.name + ".tmp")
    shutil.rmtree(staging, ignore_errors=True)
    copy_assets(modules, staging)
    (staging / STAMP_NAME).write_text(stamp_value() + "\n")
    shutil.rmtree(dest, ignore_errors=True)
    staging.rename(dest)
    print(f"vendor_web_assets: wrote {dest}")
    return dest


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dest", type=Path, default=DEFAULT_DEST, help="output folder (default: _build/vendor)")
    parser.add_argument("--force", action="store_true", help="re-copy even when the stamp matches")
    args = parser.parse_args(argv)
    vendor(args.dest, force=args.force)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
