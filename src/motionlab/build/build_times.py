"""How long a whole cold ``make book`` (and ``make test``) takes on each kind of CPU measured: the one source of
those numbers.

The README, the book's intro and ``motionlab train book`` all quote these builds; a test checks that they quote
what :func:`cold_builds` reads from ``book/data/build_times/cold_builds.json``, so a new measurement is recorded
once, there, and the pages are regenerated from it instead of being edited by hand. The README's time for ``make
test`` comes from the same file (:func:`cold_tests`). A build measured before today's plan trained all its models is
quoted with its time predicted with them (:func:`plan_change`), so an old measurement never promises too little.
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


HISTORY = RECORD.parent / "history"  # per model and chapter: <commit>-<cpu>-<precision>[-training].json


@dataclass(frozen=True)
class PlanChange:
    """The models today's laptop plan trains that a recorded build did not, and that build predicted with them."""

    added: tuple[str, ...]
    minutes: float  # the build's minutes with the added models trained, on the same CPU

    def phrase(self) -> str:
        """E.g. `` without discord/rvq-xpred (54+ min with it, predicted)``."""
        them = "it" if len(self.added) == 1 else "them"
        return f" without {', '.join(self.added)} ({round(self.minutes)}+ min with {them}, predicted)"


def plan_change(build: ColdBuild, root: str | Path | None = None) -> PlanChange | None:
    """What today's laptop training plan adds to the one ``build`` ran, and ``build``'s minutes predicted with it; None
    where it trained today's models, or where its per-model record is not in the repository.

    An added model is charged at the plan's estimate for its kind (:data:`~motionlab.build.book_models.ESTIMATES_S`, in
    the build's precision), scaled by how fast that CPU trained the models it shares with today's plan (their recorded
    seconds over their estimates); the build grows by the greedy two-worker schedule's wall time with the added models
    over without them. Chapters added since are not charged, so the prediction is a lower bound.
    """
    from .book_models import book_jobs
    from .plan import Job, expected_wall_seconds

    root = Path(root) if root is not None else book_root()
    found = sorted((root / HISTORY).glob(f"{build.commit}-*-{build.precision}-training.json")) if root else []
    if not build.commit or len(found) != 1:
        return None
    trained = {name: float(run["seconds"]) for name, run in json.loads(found[0].read_text()).items()}
    plan = book_jobs("laptop", precision=build.precision)
    added = tuple(job.name for job in plan if job.name not in trained)
    if not added:
        return None
    shared = [job for job in plan if job.name in trained]
    speed = sum(trained[job.name] for job in shared) / sum(job.estimate_s for job in shared)

    def timed(jobs) -> list[Job]:  # the build's own seconds, the speed-scaled estimate where it has none
        return [Job(j.name, print, j.after, trained.get(j.name, j.estimate_s * speed)) for j in jobs]

    then, now = expected_wall_seconds(timed(shared), 2), expected_wall_seconds(timed(plan), 2)
    return PlanChange(added, build.minutes + (now - then) / 60)


def build_phrase(build: ColdBuild, root: str | Path | None = None) -> str:
    """How the pages quote ``build``: its measured time, and, where it ran an older plan, its time predicted today."""
    change = plan_change(build, root)
    return build.phrase() + (change.phrase() if change else "")


def cold_build_line(root: str | Path | None = None) -> str:
    """One sentence with every recorded cold build (``""`` when none is recorded)."""
    builds = cold_builds(root)
    if not builds:
        return ""
    return "a whole cold `make book` (laptop) took " + "; ".join(build_phrase(b, root) for b in builds)


__all__ = [
    "HISTORY",
    "RECORD",
    "ColdBuild",
    "PlanChange",
    "book_root",
    "build_phrase",
    "cold_build_line",
    "cold_builds",
    "cold_tests",
    "plan_change",
]
