"""Quality gates for the book's sources: clean notebooks, one parameters cell, a toc that matches.

Chapters are committed without outputs (the book and CI execute them), every chapter can be driven
by papermill through exactly one ``parameters`` cell, and every notebook is a page of the book while
every page the toc names exists (``jupyter-book -W`` would fail on either mismatch, much later).
"""

from __future__ import annotations

import re
from pathlib import Path

import nbformat
import pytest
import yaml

REPO = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))
TOC = REPO / "book" / "_toc.yml"


def toc_files(node) -> list[str]:
    """Every ``file:``/``root:`` entry of a jb-book toc, in order."""
    found = []
    if isinstance(node, dict):
        for key in ("root", "file"):
            if key in node:
                found.append(str(node[key]))
        for value in node.values():
            found += toc_files(value)
    elif isinstance(node, list):
        for item in node:
            found += toc_files(item)
    return found


def resolve(entry: str) -> Path | None:
    """The source file of a toc entry (entries omit the suffix)."""
    for suffix in ("", ".ipynb", ".md"):
        path = REPO / f"{entry}{suffix}"
        if path.is_file():
            return path
    return None


def test_there_are_chapters():
    assert NOTEBOOKS, "no notebooks/*.ipynb found"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_is_committed_clean(path):
    nb = nbformat.read(path, as_version=4)
    dirty = [
        i
        for i, c in enumerate(nb.cells)
        if c.cell_type == "code" and (c.get("outputs") or c.get("execution_count") is not None)
    ]
    assert not dirty, f"{path.name}: cells {dirty} carry outputs or execution counts; clear them before committing"
    assert "widgets" not in nb.metadata, f"{path.name}: saved widget state in the notebook metadata"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_has_exactly_one_parameters_cell(path):
    nb = nbformat.read(path, as_version=4)
    tagged = [i for i, c in enumerate(nb.cells) if "parameters" in c.get("metadata", {}).get("tags", [])]
    assert len(tagged) == 1, f"{path.name}: expected one cell tagged 'parameters', found {len(tagged)}"
    cell = nb.cells[tagged[0]]
    assert cell.cell_type == "code"
    assert re.search(r"^profile\s*=", cell.source, re.MULTILINE), (
        f"{path.name}: the parameters cell must assign `profile` (papermill overrides it)"
    )
    assert "MOTIONLAB_PROFILE" in cell.source, f"{path.name}: read the default profile from $MOTIONLAB_PROFILE"


def test_every_notebook_is_in_the_toc_and_every_toc_entry_exists():
    entries = toc_files(yaml.safe_load(TOC.read_text()))
    missing = [e for e in entries if resolve(e) is None]
    assert not missing, f"book/_toc.yml names files that do not exist: {missing}"
    listed = {resolve(e) for e in entries}
    absent = [p.name for p in NOTEBOOKS if p not in listed]
    assert not absent, f"notebooks missing from book/_toc.yml: {absent}"
    assert len(entries) == len(set(entries)), "a page appears twice in the toc"


def test_local_links_in_book_pages_exist():
    """Markdown links from book/*.md to local files must resolve (``-W -n`` fails on broken ones)."""
    broken = []
    for page in sorted((REPO / "book").glob("*.md")):
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            if not (page.parent / target.split("#")[0]).exists():
                broken.append(f"{page.name} -> {target}")
    assert not broken, f"broken links: {broken}"


def test_chapter_map_links_every_chapter():
    """The intro's chapter map links each existing chapter (planned ones stay plain text)."""
    intro = (REPO / "book" / "intro.md").read_text()
    unlinked = [p.name for p in NOTEBOOKS if f"../notebooks/{p.name}" not in intro]
    assert not unlinked, f"book/intro.md: link these chapters in the chapter map: {unlinked}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_chapter_ends_by_printing_its_wall_time(path):
    nb = nbformat.read(path, as_version=4)
    assert nb.cells[-1].cell_type == "code" and nb.cells[-1].source.strip() == "book.chapter_time();"
