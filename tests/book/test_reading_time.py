"""Reading times counted from the pages: prose, shown code, shown library source and figures, at stated rates."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from motionlab.build import reading_time as rt
from motionlab.build.reading_time import ReadingTime, load_reading, prose, reading_minutes, reading_time

ROOT = Path(__file__).resolve().parents[2]


def cell(kind: str, text: str, tags: tuple[str, ...] = (), **metadata) -> dict:
    return {"cell_type": kind, "source": text, "metadata": {"tags": list(tags), **metadata}}


def test_the_rates_are_the_stated_ones():
    assert (rt.PROSE_WORDS_PER_MIN, rt.CODE_LINES_PER_MIN, rt.SECONDS_PER_FIGURE) == (200, 15, 30)
    assert ReadingTime(400, 30, 4).minutes == pytest.approx(2 + 2 + 2)
    assert (ReadingTime(1, 2, 3, ("a",)) + ReadingTime(10, 20, 30, ("b",))) == ReadingTime(11, 22, 33, ("a", "b"))


def test_prose_leaves_folded_blocks_out_and_counts_code_blocks_and_images():
    text = "\n".join(
        [
            "Five words of plain prose.",
            "```{admonition} Exercise 1.1 — a title",
            ":class: tip",
            "Three more words.",
            "```",
            "```{dropdown} Answer",
            "fifty " * 50,
            "````python",
            "x = 1",
            "````",
            "```",
            "```bash",
            "make book",
            "",
            "# a comment",
            "make test",
            "```",
            "![a figure](images/a.png) and <img src='b.png'>",
            "```{figure} images/c.png",
            ":width: 100%",
            "The caption.",
            "```",
        ]
    )
    counted = prose(text)
    # 5 + the admonition's title (5) + 3 + the image line (5) + the caption (2); options and folds left out
    assert counted.words == 5 + 5 + 3 + 5 + 2
    assert counted.code_lines == 2  # the bash block, not its blank line or comment, nor the folded python block
    assert counted.figures == 3


def test_a_code_cell_counts_what_the_page_shows():
    notebook = {
        "cells": [
            cell("code", "a = 1\nb = 2\n# comment\n\nplt.show()"),  # shown: 3 lines, 1 figure
            cell("code", "hidden = 1\n" * 9 + "plt.show()", ("hide-input",)),  # folded code, its figure shown
            cell("code", "plt.show()", ("remove-output",)),  # the code shown, the figure not
            cell("code", "fig = diagrams.pipeline()", mystnb={"figure": {"caption": "One figure."}}),
            cell("code", "profile = 'laptop'", ("parameters", "remove-cell")),
            cell("code", "plt.show()", ("remove-cell",)),
        ]
    }
    assert reading_time(notebook) == ReadingTime(0, 3 + 1 + 1, 1 + 1 + 1)


def test_library_source_shown_is_read_too():
    from motionlab import book
    from motionlab.report import rules

    shown = rt.code_lines(book.show_source(rules.Between).data)
    bare = rt.code_lines(book.show_source(rules.Between, docstring=False).data)
    assert shown > bare > 10
    notebook = {
        "cells": [
            cell("code", "from motionlab import book\nfrom motionlab.report import rules"),
            cell("code", "book.show_source(rules.Between)"),
            cell("code", "book.show_source(rules.Between, docstring=False)", ("hide-input",)),
            cell("code", "book.show_source(rules.Between)", ("hide-output",)),  # folded: not read
            cell("code", "sjpe = importlib.import_module('motionlab.report.rules')\nbook.show_source(sjpe.Less)"),
            cell("code", "book.show_source(model.forward)"),  # a runtime object: not counted, and said so
        ]
    }
    counted = reading_time(notebook)
    less = rt.code_lines(book.show_source(rules.Less).data)
    assert counted.code_lines == 2 + (1 + shown) + bare + 1 + (2 + less) + 1
    assert counted.unresolved == ("book.show_source(model.forward)",)


def test_source_as_a_list_of_lines_reads_the_same():
    notebook = {"cells": [cell("markdown", " ".join(["word"] * 400)), cell("code", "\n".join(["x = 1"] * 30))]}
    as_lists = {"cells": [{**c, "source": c["source"].splitlines(keepends=True)} for c in notebook["cells"]]}
    assert reading_minutes(notebook) == reading_minutes(as_lists) == pytest.approx(4.0)


def test_every_page_resolves_the_source_it_shows():
    pages = sorted(p.stem for p in (ROOT / "notebooks").glob("*.ipynb"))
    unresolved = {page: t.unresolved for page, t in load_reading(ROOT, pages).items() if t.unresolved}
    assert not unresolved, f"show_source arguments the reading time cannot find: {unresolved}"


def test_the_intro_shows_the_computed_reading_times():
    intro = (ROOT / "book" / "intro.md").read_text(encoding="utf-8")
    row = re.compile(r"^\| (?:\d\d|s\d) \| \[[^\]]*\]\(\.\./notebooks/(\w+)\.ipynb\) \|")
    shown = {}
    for line in intro.splitlines():
        if match := row.match(line):
            shown[match.group(1)] = line.rstrip(" |").split(" | ")[4]
    assert set(shown) == {p.stem for p in (ROOT / "notebooks").glob("*.ipynb")}
    computed = load_reading(ROOT, list(shown))
    off = {
        page: (text, round(computed[page].minutes, 1))
        for page, text in shown.items()
        if not text.isdigit() or abs(int(text) - computed[page].minutes) > 1
    }
    assert not off, f"book/intro.md's read (min) column against the pages (run tools/chapter_map.py): {off}"
    flat = " ".join(intro.split())
    assert "200 words a minute" in flat and "15 lines a minute" in flat and "30 seconds for each figure" in flat


def test_reading_a_notebook_file(tmp_path):
    (tmp_path / "notebooks").mkdir()
    page = {"cells": [cell("markdown", "one two three four")], "metadata": {}, "nbformat": 4, "nbformat_minor": 5}
    (tmp_path / "notebooks" / "x.ipynb").write_text(json.dumps(page))
    assert load_reading(tmp_path, ["x"]) == {"x": ReadingTime(4, 0, 0)}
