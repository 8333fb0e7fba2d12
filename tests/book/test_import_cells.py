"""Short import cells: a chapter imports modules and calls names through them.

A chapter's page opens with its imports, so they are part of what the reader reads: ``from motionlab import flow,
metrics, viz`` and then ``flow.sample(...)`` says where each name lives, where a 40-name list says nothing. The
measure is each code cell's *import block*: the lines from the cell's first line to the end of the last top-level
``import``/``from ... import`` statement before the cell's first other statement, counted as the reader sees them
(a parenthesised import counts every line it spans; blank lines and comments between the imports count too). Every
code cell of every notebook, tagged ``remove-input``/``hide-input`` or not, keeps that block to at most
:data:`MAX_IMPORT_LINES` lines; a name a chapter uses once is imported in the cell that uses it or called through
its module.
"""

from __future__ import annotations

import ast
from pathlib import Path

import nbformat
import pytest

REPO = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))
MAX_IMPORT_LINES = 12


def import_block_lines(source: str) -> int:
    """Lines from the top of ``source`` to the end of its leading import statements (0 when it starts otherwise)."""
    lines = ["" if line.lstrip().startswith(("%", "!")) else line for line in source.splitlines()]
    end = 0
    for node in ast.parse("\n".join(lines)).body:
        if not isinstance(node, (ast.Import, ast.ImportFrom)):
            break
        end = node.end_lineno
    return end


def test_import_block_counts_what_the_reader_sees():
    assert import_block_lines("x = 1\nimport os") == 0
    assert import_block_lines("import os\n\nfrom a import (\n    b,\n    c,\n)\nx = 1\nimport sys") == 6
    assert import_block_lines("# comment\nimport os") == 2


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_no_import_cell_is_longer_than_a_dozen_lines(path):
    nb = nbformat.read(path, as_version=4)
    long = [
        f"cell {i}: {n} import lines"
        for i, cell in enumerate(nb.cells)
        if cell.cell_type == "code" and (n := import_block_lines(cell.source)) > MAX_IMPORT_LINES
    ]
    assert not long, (
        f"{path.name}: import modules (`from motionlab import flow, viz`) and call names through them "
        f"(at most {MAX_IMPORT_LINES} lines): " + "; ".join(long)
    )
