"""Small tables a library function computed, rendered for reading (Markdown in Jupyter and in the book).

A :class:`Table` is rows × named columns. A measured cell is an :class:`~motionlab.estimate.Estimate` and prints as
one (``52.3 ± 3.1 mm``: two significant digits of the half-width); a plain number prints with three significant
digits, an int with thousands separators, a missing cell as "–"; a column may carry its own format spec instead
(``".4f"``, ``".1e"``, ``".0%"``). Columns of numbers are right-aligned.

The chapters build no Markdown by hand: they call a function that returns a :class:`Table` (e.g.
:func:`skeleton_table`, :func:`motionlab.studies.tokenizer_analysis.usage_table`) and make it a cell's last line.
"""

from __future__ import annotations

import numbers
from collections.abc import Hashable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from motionlab.estimate import Estimate, format_number

MISSING = "–"


def format_cell(value: Any, spec: str = "") -> str:
    """One cell as text: an Estimate as it prints, a float to 3 significant digits, an int with separators; with a
    format ``spec`` (e.g. ``".4f"``), numbers and Estimates are formatted by it instead."""
    if value is None:
        return MISSING
    if spec and _numeric(value):
        text = format(value if isinstance(value, Estimate) else float(value), spec)
    elif isinstance(value, Estimate):
        text = f"{value}"
    elif isinstance(value, (bool, np.bool_)):
        text = "yes" if value else "no"
    elif isinstance(value, numbers.Integral):
        text = f"{int(value):,}"
    elif isinstance(value, numbers.Real):
        text = format_number(float(value))
    else:
        text = str(value)
    return text.replace("|", "\\|")  # a literal bar would end the cell


def _numeric(value: Any) -> bool:
    return value is None or isinstance(value, (Estimate, numbers.Real)) and not isinstance(value, (bool, np.bool_))


@dataclass(frozen=True)
class Table:
    """Rows × columns for reading: ``rows[label][column]`` is a cell (Estimate, number, text or None).

    ``index`` is the header of the row-label column; ``columns`` orders the columns (default: every key of the rows,
    in first-seen order); ``formats`` maps a column to the format spec of its numbers; ``notes`` are printed under
    the table.
    """

    index: str
    rows: Mapping[Hashable, Mapping[str, Any]]
    columns: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    formats: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self):
        if not self.rows:
            raise ValueError("rows is empty")
        object.__setattr__(self, "rows", {label: dict(cells) for label, cells in self.rows.items()})
        if not self.columns:
            object.__setattr__(self, "columns", tuple(dict.fromkeys(k for c in self.rows.values() for k in c)))
        object.__setattr__(self, "columns", tuple(self.columns))
        object.__setattr__(self, "notes", tuple(self.notes))
        unknown = set(self.formats) - set(self.columns)
        if unknown:
            raise ValueError(f"formats for columns the table lacks: {sorted(unknown)}")

    @property
    def labels(self) -> list:
        """The row labels, in order."""
        return list(self.rows)

    def cell(self, row: Hashable, column: str) -> Any:
        """The cell ``rows[row][column]``; a missing row or column is named with what the table has."""
        if row not in self.rows:
            raise KeyError(f"no row {row!r}; rows: {self.labels}")
        if column not in self.rows[row]:
            raise KeyError(f"row {row!r} has no {column!r} (no column of that name); it has {list(self.rows[row])}")
        return self.rows[row][column]

    def column(self, column: str) -> list:
        """One column, row by row (rows lacking it are skipped)."""
        if column not in self.columns:
            raise KeyError(f"no column {column!r}; columns: {list(self.columns)}")
        return [cells[column] for cells in self.rows.values() if column in cells]

    def compare(self, row_a: Hashable, row_b: Hashable, column: str, name_a: str | None = None, name_b=None):
        """``row_a`` against ``row_b`` in ``column`` by the one rule (:func:`motionlab.comparison.compare`)."""
        from motionlab.comparison import compare

        return compare(
            self.cell(row_a, column),
            self.cell(row_b, column),
            name_a or str(row_a),
            name_b or str(row_b),
            quantity=column,
        )

    def header(self, column: str) -> str:
        """A column's header as printed (subclasses name their columns for reading)."""
        return column

    def row_label(self, label: Hashable) -> str:
        """A row's label as printed."""
        return format_cell(label)

    def to_markdown(self) -> str:
        align = ["---"] + [
            "---:" if all(_numeric(c.get(k)) for c in self.rows.values()) else "---" for k in self.columns
        ]
        lines = [
            "| " + " | ".join([self.index, *(self.header(k) for k in self.columns)]) + " |",
            "|" + "|".join(align) + "|",
        ]
        for label, cells in self.rows.items():
            values = [self.row_label(label)] + [
                format_cell(cells.get(k), self.formats.get(k, "")) for k in self.columns
            ]
            lines.append("| " + " | ".join(values) + " |")
        return "\n".join(lines + [f"\n{note}" for note in self.notes])

    def _repr_markdown_(self) -> str:
        return self.to_markdown()

    def __str__(self) -> str:
        return self.to_markdown()


# ----------------------------------------------------------------------------------------------- chapter 01's tables


def skeleton_table(skeleton: Any = "t2m") -> Table:
    """One row per joint of ``skeleton`` (a name or :class:`~motionlab.representation.Skeleton`): its name, its
    parent's name and the length of the bone from the parent, in metres."""
    from motionlab.representation import get_skeleton

    sk = get_skeleton(skeleton)
    rows = {
        j: {
            "name": name,
            "parent": sk.joint_names[parent] if parent >= 0 else None,
            "bone length (m)": float(sk.bone_lengths[j]) if parent >= 0 else None,  # the root ends no bone
        }
        for j, (name, parent) in enumerate(zip(sk.joint_names, sk.parents, strict=True))
    }
    return Table("joint", rows, formats={"bone length (m)": ".4f"})


def feature_differences(features: np.ndarray, reference: np.ndarray, skeleton: Any = "t2m") -> Table:
    """The largest absolute difference between two feature arrays ``(T, D)``, per feature group of ``skeleton``
    (:func:`~motionlab.representation.feature_slices`); ``reference`` may be longer (its first T frames count)."""
    from motionlab.representation import feature_slices

    a, b = np.asarray(features, dtype=np.float64), np.asarray(reference, dtype=np.float64)
    groups = feature_slices(skeleton)
    width = max(s.stop for s in groups.values())
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != width or b.shape[1] != width or len(b) < len(a) or not len(a):
        raise ValueError(f"need features (T >= 1, {width}) and reference (>= T, {width}), got {a.shape} and {b.shape}")
    b = b[: len(a)]
    rows = {name: {"max abs difference": float(np.abs(a[:, s] - b[:, s]).max())} for name, s in groups.items()}
    return Table("group", rows, formats={"max abs difference": ".1e"})


__all__ = ["Table", "feature_differences", "format_cell", "skeleton_table"]
