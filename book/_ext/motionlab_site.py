"""Sphinx extension for the book's site: no console errors, offline widget fonts, a layout for results.

- **One copy of each inline script.** Jupyter Book 1 registers sphinx-thebe's and sphinx-togglebutton's inline
  configuration scripts twice; the second ``const THEBE_JS_URL = ...`` is a SyntaxError on every page. Pages keep the
  first of identical inline scripts.
- **Static files** of this folder's ``static/``: ``motionlab.css`` (every page) and ``widgets-setup.js``, which
  ``_config.yml`` loads between require.js and the widget bundle (see that file).

Jupyter Book loads it through ``sphinx: local_extensions`` in ``_config.yml``.
"""

from __future__ import annotations

from pathlib import Path

STATIC = Path(__file__).resolve().parent / "static"


def _add_static_path(app) -> None:
    app.config.html_static_path.append(str(STATIC))


def _dedupe_inline_scripts(app, pagename, templatename, context, doctree) -> None:
    scripts = context.get("script_files")
    if not scripts:
        return
    seen, unique = set(), []
    for script in scripts:
        body = getattr(script, "attributes", {}).get("body")
        key = (getattr(script, "filename", None) or "", body)  # the copies differ in priority and in None vs ""
        if body and key in seen:
            continue
        seen.add(key)
        unique.append(script)
    scripts[:] = unique


def setup(app):
    app.connect("builder-inited", _add_static_path)
    # early: Sphinx stops calling html-page-context handlers at the first that returns a value (a template name)
    app.connect("html-page-context", _dedupe_inline_scripts, priority=100)
    app.add_css_file("motionlab.css")
    return {"parallel_read_safe": True, "parallel_write_safe": True}
