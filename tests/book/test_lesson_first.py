"""Chapters read as lessons: the idea and its picture first, the audit last (issue 61), checked on the sources.

A scan of the chapters' Markdown and cell metadata; the built site is checked in a browser by
``test_browser_site.py``. What a reader sees as prose here is a Markdown cell's text without fenced code, display
math and folded blocks (``{dropdown}`` directives, admonitions of class ``dropdown``).
"""

from __future__ import annotations

import re
from pathlib import Path

import nbformat
import pytest

REPO = Path(__file__).resolve().parents[2]
CHAPTERS = sorted((REPO / "notebooks").glob("0*.ipynb"))  # 01-09: the chapters that teach one idea each
ALL_PAGES = sorted((REPO / "notebooks").glob("*.ipynb"))
WHAT_REPRODUCES = REPO / "notebooks" / "99_what_reproduces.ipynb"

# Words whose subject is the machinery of a run rather than the idea (the list).
AUDIT = re.compile(
    r"\b(seeds?|commits?|precision|bf16|fp32|cach(?:e|es|ed)|recorded|records?|CPUs?|AMD|EPYC|Zen|AVX\w*|"
    r"training runs?|profiles?|this build|sittings?|budgets?)\b",
    re.IGNORECASE,
)
WORD = re.compile(r"[A-Za-z][A-Za-z0-9'’-]*")
FENCE = re.compile(r"^\s*(`{3,}|:{3,})\s*(\{([\w-]+)\})?(.*)$")
SHOWN_DIRECTIVES = {"admonition", "note", "tip", "important", "warning", "seealso"}
FIGURE_CALL = re.compile(r"plt\.show\(\)|diagrams\.\w+\.\w+\(")


def visible_prose(markdown: str) -> str:
    """The text of a Markdown cell a reader sees unfolded: no fenced code, no display math, no folded block, no
    directive options; the text inside visible directives (an exercise's admonition) stays."""
    kept, stack = [], []  # stack: (fence, shown) of the open fenced blocks
    for line in markdown.splitlines():
        match = FENCE.match(line)
        if match and stack and match.group(1) == stack[-1][0] and not match.group(2) and not match.group(4).strip():
            stack.pop()
            continue
        if match and (match.group(2) or not stack or stack[-1][1]):
            # a visible directive (an exercise's admonition) shows its text; a dropdown, a code block or math does not
            shown = match.group(3) in SHOWN_DIRECTIVES
            stack.append((match.group(1), shown and all(s for _, s in stack)))
            if stack[-1][1] and match.group(4).strip():
                kept.append(match.group(4))  # an admonition's title
            continue
        if stack and not stack[-1][1]:
            continue
        if stack and re.match(r"^\s*:class:.*dropdown", line):
            stack[-1] = (stack[-1][0], False)
            continue
        if re.match(r"^\s*:[\w-]+:", line):
            continue  # a directive's option
        kept.append(line)
    text = "\n".join(kept)
    text = re.sub(r"\$\$.*?\$\$", " ", text, flags=re.DOTALL)
    text = re.sub(r"\\begin\{(\w+\*?)\}.*?\\end\{\1\}", " ", text, flags=re.DOTALL)
    text = re.sub(r"<!--.*?-->", " ", text, flags=re.DOTALL)
    return re.sub(r"\{cite:\w+\}`[^`]*`", " ", text)


def prose(path: Path) -> str:
    nb = nbformat.read(path, as_version=4)
    return "\n".join(visible_prose(c.source) for c in nb.cells if c.cell_type == "markdown")


def audit_rate(text: str) -> tuple[float, int, int]:
    """Audit words per 1,000 words of ``text``, the audit words and all words."""
    words = len(WORD.findall(text))
    audit = len(AUDIT.findall(text))
    return 1000 * audit / max(words, 1), audit, words


def test_visible_prose_drops_code_math_and_folded_blocks():
    source = (
        "The idea in words, seed one.\n\n$$\nx = y\n$$\n\n```python\nseed = 0\n```\n\n"
        "```{admonition} Exercise 1.1 — a title\n:class: tip\nTry the precision.\n```\n\n"
        "```{dropdown} Answer\nThe seed and the commit.\n```\n\n"
        "```{admonition} Folded\n:class: dropdown\nbudget budget\n```\nAfter."
    )
    text = visible_prose(source)
    assert "The idea in words" in text and "Exercise 1.1" in text and "Try the precision" in text
    assert "x = y" not in text and "seed = 0" not in text and "commit" not in text and "budget" not in text
    assert text.rstrip().endswith("After.")
    assert audit_rate(text)[1] == 2  # "seed" in the first line, "precision" in the exercise


@pytest.mark.parametrize("path", [*CHAPTERS, WHAT_REPRODUCES], ids=lambda p: p.stem)
def test_prose_is_about_the_ideas_not_the_runs(path):
    limit = 25 if path == WHAT_REPRODUCES else 8
    rate, audit, words = audit_rate(prose(path))
    found = sorted({m.lower() for m in AUDIT.findall(prose(path))})
    assert rate <= limit, f"{path.stem}: {audit} audit words in {words} ({rate:.1f} per 1,000 > {limit}): {found}"


def exercises(path: Path) -> list[tuple[str, list[str]]]:
    """Each exercise's title and the titles of the folded blocks that follow it, up to the next exercise."""
    nb = nbformat.read(path, as_version=4)
    text = "\n".join(c.source for c in nb.cells if c.cell_type == "markdown")
    found: list[tuple[str, list[str]]] = []
    for match in re.finditer(r"^\s*(`{3,}|:{3,})\s*\{(admonition|dropdown)\}\s*(.*)$", text, re.MULTILINE):
        kind, title = match.group(2), match.group(3).strip()
        if kind == "admonition" and title.startswith("Exercise"):
            found.append((title, []))
        elif kind == "dropdown" and found:
            found[-1][1].append(title)
    return found


@pytest.mark.parametrize("path", ALL_PAGES, ids=lambda p: p.stem)
def test_every_exercise_has_a_hint_and_a_worked_answer(path):
    unanswered = [
        title
        for title, folds in exercises(path)
        if not any(f.startswith("Hint") for f in folds) or not any(f.startswith("Answer") for f in folds)
    ]
    assert not unanswered, f"{path.stem}: exercises without a folded Hint and Answer: {unanswered}"


def figure_cells(path: Path) -> list[tuple[int, nbformat.NotebookNode]]:
    """Code cells that show a figure: a ``plt.show()`` or a diagram, unless their output is removed."""
    nb = nbformat.read(path, as_version=4)
    return [
        (i, c)
        for i, c in enumerate(nb.cells)
        if c.cell_type == "code"
        and FIGURE_CALL.search(c.source)
        and not {"remove-output", "remove-cell"} & set(c.metadata.get("tags", []))
    ]


def caption(cell) -> str:
    """The figure caption a cell carries: its myst-nb figure metadata, or the ``caption=`` of its ``book.try_it``."""
    found = re.search(r"book\.try_it\((?s:.*?)caption=((?:\s*f?\"[^\"]*\"\s*)+)", cell.source)
    return str(cell.metadata.get("mystnb", {}).get("figure", {}).get("caption", "")) or (
        found.group(1) if found else ""
    )


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_every_figure_has_a_caption(path):
    cells = figure_cells(path)
    assert cells, f"{path.stem} shows no figure"
    bare = [i for i, c in cells if len(WORD.findall(caption(c))) < 6]
    assert not bare, f"{path.stem}: figure cells {bare} need a caption (mystnb.figure.caption, a sentence)"
    named = [i for i, c in cells if c.metadata.get("mystnb", {}).get("figure", {}).get("name")]
    assert not named, f"{path.stem}: cells {named} name their figure (duplicate labels break the -W build)"


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_a_picture_of_the_idea_comes_before_the_details(path):
    nb = nbformat.read(path, as_version=4)
    diagram = next(
        (i for i, c in enumerate(nb.cells) if c.cell_type == "code" and re.search(r"diagrams\.\w+\.\w+\(", c.source)),
        None,
    )
    assert diagram is not None, f"{path.stem}: no diagram of the method (motionlab.viz.diagrams)"
    before = sum(len(WORD.findall(visible_prose(c.source))) for c in nb.cells[:diagram] if c.cell_type == "markdown")
    assert before <= 600, f"{path.stem}: {before} words of prose before the first diagram (cell {diagram})"


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_the_verdicts_come_after_the_lesson(path):
    nb = nbformat.read(path, as_version=4)
    sources = [c.source for c in nb.cells]
    assert not any("findings_box" in s for s in sources), f"{path.stem}: the findings box opens the chapter"
    end = [i for i, s in enumerate(sources) if "book.what_reproduces_here(" in s]
    assert len(end) == 1, f"{path.stem}: expected one book.what_reproduces_here(...) cell, found {end}"
    assert end[0] >= 0.6 * len(sources), f"{path.stem}: 'What reproduces here' at cell {end[0]} of {len(sources)}"
    records = [i for i, s in enumerate(sources) if re.search(r"results\.record\w*\(", s)]
    assert all(i < end[0] for i in records), f"{path.stem}: results recorded after the table that reads them"
    heading = [i for i, c in enumerate(nb.cells) if c.cell_type == "markdown" and "## What reproduces here" in c.source]
    assert heading and heading[0] < end[0], f"{path.stem}: no '## What reproduces here' heading before the table"
