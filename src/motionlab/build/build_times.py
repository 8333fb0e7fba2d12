"""How long a whole cold ``make book`` (and ``make test``) takes on each kind of CPU measured: the one source of
those numbers.

The README, the book's intro and ``motionlab train book`` all quote these builds; a test checks that they quote
what :func:`cold_builds` reads from ``book/data/build_times/cold_builds.json``, so a new measurement is recorded
once, there, and the pages are regenerated from it instead of being edited by hand. The README's time for ``make
test`` comes from the same file (:func:`cold_tests`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

RECORD = Path("book") / "data" / "build_times" / "cold_builds.json"


@dataclass(frozen=True)
class ColdBuild:
    """One measured cold build: the CPU, the precision ``auto`` picked there, wall minutes, where and when."""

    cpu: str
    precision: str
    minutes: float
    commit: str | None = None
    date: str = ""
    note: str = ""

    def phrase(self) -> str:
        """E.g. ``about 44 min on an AMD EPYC Zen 3, AVX2 only (fp32)``: how the pages quote it."""
        return f"about {round(self.minutes)} min on an {self.cpu} ({self.precision})"


def book_root() -> Path | None:
    """The book's repository this package was installed from (editable install), or None for a plain install."""
    root = Path(__file__).resolve().parents[3]
    return root if (root / "book" / "_toc.yml").is_file() else None


def _recorded(root: str | Path | None, kind: str) -> list[ColdBuild]:
    root = Path(root) if root is not None else book_root()
    if root is None or not (root / RECORD).is_file():
        return []
    runs = [ColdBuild(**entry) for entry in json.loads((root / RECORD).read_text()).get(kind, [])]
    return sorted(runs, key=lambda b: -b.minutes)


def cold_builds(root: str | Path | None = None) -> list[ColdBuild]:
    """The recorded cold builds, slowest first; ``[]`` where the record is absent (outside the repository)."""
    return _recorded(root, "builds")


def cold_tests(root: str | Path | None = None) -> list[ColdBuild]:
    """The recorded cold ``make test`` runs (a fresh clone: new ``.venv``, empty model cache), slowest first."""
    return _recorded(root, "tests")


def cold_build_line(root: str | Path | None = None) -> str:
    """One sentence with every recorded cold build (``""`` when none is recorded)."""
    builds = cold_builds(root)
    if not builds:
        return ""
    return "a whole cold `make book` (laptop) took " + "; ".join(b.phrase() for b in builds)


__all__ = ["RECORD", "ColdBuild", "book_root", "cold_build_line", "cold_builds", "cold_tests"]
