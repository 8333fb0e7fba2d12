"""How long a first reading of a page takes, counted from its notebook: the intro's chapter map shows it.

A first reading goes through what the page shows unfolded, and nothing else:

- **prose**: the words of the Markdown cells at :data:`PROSE_WORDS_PER_MIN`, less the folded ``{dropdown}`` blocks
  (hints and answers open on a click) and directive options (``:class: tip``);
- **code**: the lines of code the page shows at :data:`CODE_LINES_PER_MIN`, not counting blank lines and comments:
  the code cells whose input is not folded or removed, the code blocks in the prose, and the library source a cell
  shows with ``book.show_source(...)`` where its output is not folded (resolved through the notebook's own imports);
- **figures**: :data:`SECONDS_PER_FIGURE` for each figure the page shows: a code cell captioned as a figure
  (``mystnb.figure`` metadata), else each ``plt.show()`` of a cell whose output is shown, and each image in the prose.

Tables, printed numbers and widgets are not counted: the time is a floor for a first reading, not for working the
exercises. ``python tools/chapter_map.py`` writes the minutes into the intro's chapter map.
"""

from __future__ import annotations

import ast
import json
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

PROSE_WORDS_PER_MIN = 200  # an ordinary pace for technical prose
CODE_LINES_PER_MIN = 15  # code is read line by line, slower than prose
SECONDS_PER_FIGURE = 30  # a figure is looked at: its axes, its legend, what the caption points to

# cell tags that hide a cell's input (its code) or its output on the rendered page
INPUT_FOLDED = frozenset({"hide-input", "remove-input", "hide-cell", "remove-cell", "parameters"})
OUTPUT_FOLDED = frozenset({"hide-output", "remove-output", "hide-cell", "remove-cell"})

_FENCE = re.compile(r"^\s*(`{3,}|:{3,})\s*(.*)$")
_OPTION = re.compile(r"^\s*:[\w-]+:")  # a directive option line, e.g. ":class: tip"
_IMAGE = re.compile(r"!\[[^\]]*\]\([^)]*\)|<img\b", re.IGNORECASE)
_SHOW = re.compile(r"\bplt\.show\(")


@dataclass(frozen=True)
class ReadingTime:
    """What a first reading of one page goes through, and how long it takes (:attr:`minutes`)."""

    words: int  # prose words, folded blocks left out
    code_lines: int  # shown code lines: cells, code blocks in the prose, library source shown
    figures: int
    unresolved: tuple[str, ...] = ()  # ``show_source`` arguments the count could not find (their lines not counted)

    @property
    def minutes(self) -> float:
        return (
            self.words / PROSE_WORDS_PER_MIN
            + self.code_lines / CODE_LINES_PER_MIN
            + self.figures * SECONDS_PER_FIGURE / 60
        )

    def __add__(self, other: ReadingTime) -> ReadingTime:
        return ReadingTime(
            self.words + other.words,
            self.code_lines + other.code_lines,
            self.figures + other.figures,
            self.unresolved + other.unresolved,
        )


def _text(cell: Mapping[str, Any]) -> str:
    source = cell.get("source", "")
    return "".join(source) if isinstance(source, list) else source


def _tags(cell: Mapping[str, Any]) -> set[str]:
    return set(cell.get("metadata", {}).get("tags", []))


def code_lines(source: str) -> int:
    """Lines of ``source`` a reader reads: not blank, not a comment."""
    return sum(1 for line in source.splitlines() if line.strip() and not line.lstrip().startswith("#"))


def prose(markdown: str) -> ReadingTime:
    """Words, code lines and images of one Markdown cell as the page shows it, ``{dropdown}`` blocks folded."""
    words = lines = figures = 0
    stack: list[tuple[str, int, str]] = []  # open fences: (character, length, "code" | "folded" | "directive")
    for line in markdown.splitlines():
        fence = _FENCE.match(line)
        top = stack[-1] if stack else None
        if fence:
            marker, info = fence.group(1), fence.group(2).strip()
            if top and marker[0] == top[0] and len(marker) >= top[1] and not info:
                stack.pop()  # closes the innermost open fence
                continue
            if not top or top[2] != "code":  # inside a code block, a fence is text
                folded = any(kind == "folded" for _, _, kind in stack) or info.startswith("{dropdown}")
                directive = info.startswith("{")
                kind = "folded" if folded else "directive" if directive else "code"
                stack.append((marker[0], len(marker), kind))
                if kind == "directive" and info.startswith(("{figure}", "{image}")):
                    figures += 1
                elif kind == "directive" and info.startswith("{admonition}"):
                    words += len(info.split()) - 1  # its title is shown
                continue
        if any(kind == "folded" for _, _, kind in stack):
            continue
        if top and top[2] == "code":
            lines += code_lines(line)
            continue
        if _OPTION.match(line):
            continue
        figures += len(_IMAGE.findall(line))
        words += len(line.split())
    return ReadingTime(words, lines, figures)


class _Imports:
    """The names a notebook's import statements bind, imported only when a ``show_source`` argument needs them."""

    def __init__(self, cells: Iterable[str]) -> None:
        self.statements: dict[str, tuple[str, str | None]] = {}  # name -> (module, attribute or None)
        for source in cells:
            try:
                tree = ast.parse(source)
            except SyntaxError:
                continue
            for node in tree.body:
                if isinstance(node, ast.Import):
                    for alias in node.names:
                        if alias.asname:
                            self.statements[alias.asname] = (alias.name, None)
                        else:
                            root = alias.name.split(".")[0]
                            self.statements[root] = (root, None)
                elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                    for alias in node.names:
                        self.statements[alias.asname or alias.name] = (node.module, alias.name)
                elif (module := _import_module_call(node)) is not None:  # name = importlib.import_module("...")
                    self.statements[node.targets[0].id] = (module, None)

    def resolve(self, dotted: str) -> Any:
        """The object ``dotted`` (``results.Between``, ``DisCoRDDecoder.sample``) names in the notebook."""
        from importlib import import_module

        root, *rest = dotted.split(".")
        if root not in self.statements:
            raise LookupError(f"{root} is not imported by the notebook")
        module, attribute = self.statements[root]
        obj = import_module(module)
        if attribute is not None:
            obj = getattr(obj, attribute) if hasattr(obj, attribute) else import_module(f"{module}.{attribute}")
        for part in rest:
            obj = getattr(obj, part)
        return obj


def _import_module_call(node: ast.AST) -> str | None:
    """The module of ``name = importlib.import_module("a.b")`` (None for any other statement)."""
    if not (isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name)):
        return None
    call = node.value
    if not (isinstance(call, ast.Call) and _dotted(call.func) in ("importlib.import_module", "import_module")):
        return None
    first = call.args[0] if call.args else None
    return first.value if isinstance(first, ast.Constant) and isinstance(first.value, str) else None


def _dotted(node: ast.AST) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute) and (base := _dotted(node.value)) is not None:
        return f"{base}.{node.attr}"
    return None


def shown_source(source: str, imports: _Imports) -> ReadingTime:
    """The library source lines the ``book.show_source(...)`` calls of one cell put on the page."""
    from motionlab.book import show_source

    try:
        tree = ast.parse(source)
    except SyntaxError:
        return ReadingTime(0, 0, 0)
    lines, unresolved = 0, []
    for node in ast.walk(tree):
        name = getattr(node.func, "attr", getattr(node.func, "id", "")) if isinstance(node, ast.Call) else ""
        if name != "show_source":
            continue
        dotted = _dotted(node.args[0]) if node.args else None
        docstring = next((k.value for k in node.keywords if k.arg == "docstring"), ast.Constant(True))
        try:
            if dotted is None or not isinstance(docstring, ast.Constant):
                raise LookupError("not a dotted name")
            lines += code_lines(show_source(imports.resolve(dotted), docstring=bool(docstring.value)).data)
        except (LookupError, AttributeError, ImportError, ValueError):
            unresolved.append(ast.unparse(node))
    return ReadingTime(0, lines, 0, tuple(unresolved))


def reading_time(notebook: Mapping[str, Any]) -> ReadingTime:
    """What a first reading of ``notebook`` (its JSON, or an ``nbformat`` notebook) goes through."""
    cells = notebook.get("cells", [])
    imports = _Imports(_text(c) for c in cells if c.get("cell_type") == "code")
    total = ReadingTime(0, 0, 0)
    for cell in cells:
        text, tags = _text(cell), _tags(cell)
        if cell.get("cell_type") == "markdown":
            total += prose(text)
            continue
        if cell.get("cell_type") != "code":
            continue
        if not INPUT_FOLDED & tags:
            total += ReadingTime(0, code_lines(text), 0)
        if not OUTPUT_FOLDED & tags:
            captioned = "figure" in cell.get("metadata", {}).get("mystnb", {})
            total += ReadingTime(0, 0, 1 if captioned else len(_SHOW.findall(text)))
            if "show_source" in text:
                total += shown_source(text, imports)
    return total


def reading_minutes(notebook: Mapping[str, Any]) -> float:
    """Minutes a first reading of ``notebook`` takes: :func:`reading_time` at the module's rates."""
    return reading_time(notebook).minutes


def load_reading(root: str | Path, chapters: Iterable[str]) -> dict[str, ReadingTime]:
    """``{chapter: ReadingTime}`` of the notebooks ``notebooks/<chapter>.ipynb`` under ``root``."""
    folder = Path(root) / "notebooks"
    return {c: reading_time(json.loads((folder / f"{c}.ipynb").read_text(encoding="utf-8"))) for c in chapters}
