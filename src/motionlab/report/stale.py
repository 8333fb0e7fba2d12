"""Which committed measurements the working tree makes stale, and what measuring each again costs, before anything runs.

Every study record under ``book/data/`` carries the configs it was measured with, and the book sets a record aside
when they are no longer the code's (a change to :mod:`motionlab.sizes`, a model or an evaluation). This module asks
the same question of every record at once, with the readers' own comparisons (:func:`~motionlab.evaluation.scale.
point_changes`, :func:`~motionlab.evaluation.studies.budget_changes`, :func:`~motionlab.evaluation.studies.
guidance_changes` and the training-seed study's), and says for
each stale record the command that measures it again and what its last measurement cost. ``motionlab book stale``
prints it; run it after changing a studied model, before committing.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from .budget import ETA_FOLDER
from .budget import FOLDER as BUDGET_FOLDER
from .guidance import FOLDER as GUIDANCE_FOLDER
from .scale import FOLDER as SCALE_FOLDER
from .spread import FOLDER as SEEDS_FOLDER
from .spread import embedded_data_folder, stale_reason


@dataclass(frozen=True)
class StaleRecord:
    """A committed record the code no longer reproduces: why, the command that measures it again, its last cost."""

    path: Path
    why: str
    command: str
    cost: str

    def line(self, root: Path) -> str:
        where = self.path.relative_to(root) if self.path.is_relative_to(root) else self.path
        return f"{where}: {self.why}\n    again: {self.command}\n    last time: {self.cost}"


def _records(parts: tuple[str, ...], profile: str) -> Iterator[tuple[Path, dict]]:
    folder = embedded_data_folder(parts)
    for path in sorted(folder.glob("*.json")) if folder is not None and folder.is_dir() else ():
        record = json.loads(path.read_text())
        if record.get("profile") == profile:
            yield path, record


def _cost(seconds: float | None, record: dict) -> str:
    if seconds is None:
        return "not recorded"
    where = f"{record.get('cpu') or record.get('device', 'an unnamed machine')}, {record.get('precision', '?')}"
    return f"{seconds / 60:.0f} min on {where}"


def _why(changes: list[str] | None) -> str | None:
    from motionlab.evaluation.studies import changes_phrase

    if changes is None:
        return "recorded without the configs it was measured with"
    return changes_phrase(changes) if changes else None


def stale_records(profile: str = "laptop") -> list[StaleRecord]:
    """Every committed record of ``profile`` (scale points, training-seed runs, budget and η models, guidance spaces)
    whose configs differ from the code's, in that order; [] where every record measures the code as it is (or outside
    the repository, where there are none)."""
    from motionlab.evaluation.scale import point_changes
    from motionlab.evaluation.studies import budget_changes, guidance_changes

    script = "PYTHONPATH=src python experiments"
    stale = []
    for path, record in _records(SCALE_FOLDER, profile):
        if record.get("study") == "scale" and (why := _why(point_changes(record, profile))):
            point = f"--multiples {record['multiple']:g} --groups {record['group']}"
            command = f"{script}/scale.py --device {record.get('device_type', 'cpu')} {point} --profile {profile}"
            seconds = record["seconds"]["training"] + record["seconds"]["scoring"]
            stale.append(StaleRecord(path, why, command, _cost(seconds, record)))
    current: dict[str, dict] = {}  # the code's configs per study, built once
    for path, record in _records(SEEDS_FOLDER, profile):
        if why := stale_reason(record, current, profile):
            seeds = f"--study {record['study']} --seeds {record['training_seed']} --profile {profile}"
            command = f"{script}/training_seeds.py {seeds}"  # in this machine's precision; the cost says the record's
            stale.append(StaleRecord(path, why, command, _cost(record["seconds"].get("seconds"), record)))
    for parts in (BUDGET_FOLDER, ETA_FOLDER):
        for path, record in _records(parts, profile):
            if why := _why(budget_changes(record, profile)):
                if "eta" in record:
                    which = f"--etas {record['eta']:g}"
                else:
                    which = f"--arm {record['arm']} --seeds {record['training_seed']} --steps {record['steps']}"
                command = f"{script}/m2d2m_budget.py {which} --profile {profile}"
                stale.append(StaleRecord(path, why, command, _cost(record["training"].get("seconds"), record)))
    for path, record in _records(GUIDANCE_FOLDER, profile):
        if why := _why(guidance_changes(record, profile)):
            command = (
                f"{script}/guidance_space.py --spaces {record.get('guidance_on', 'x0 posterior')} --profile {profile}"
            )
            stale.append(StaleRecord(path, why, command, _cost(record["seconds"].get("seconds"), record)))
    return stale


__all__ = ["StaleRecord", "stale_records"]
