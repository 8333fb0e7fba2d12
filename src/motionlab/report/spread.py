"""How far retraining moves a claim's numbers, and the verdict every machine shares.

A chapter's number comes from one trained model. Its interval (sampling seeds, test clips) says how well that model
was measured, not how far another training run — another seed, another CPU, another precision — would land. A
verdict judged on one run can flip between two machines. The training-seed study (``experiments/training_seeds.py``)
trains the same models again with other seeds, on machines of more than one precision, and records every claim number
per run under ``book/data/training_seeds/embedded-v<N>/``; :class:`TrainingSpread` reads those files.

The rule (stated on chapter 99): a comparison of ``a`` with ``b`` whose numbers the study measured is judged on the
mean of ``d = a − b`` over the training runs: the recorded runs and this build, which takes the place of the recorded
run it repeats (seed 0 in its precision). Its 95% interval is ``t_{0.975, n−1} · sd(d) / √n``, joined in quadrature
with this build's measurement interval over ``√n`` (every run is measured alike) and, where recorded, the test-clip
interval (every run shares the test clips). A build that lands anywhere the recorded runs landed moves the mean by
``1/n`` of its own shift, so machines read the same verdict (:func:`motionlab.report.render.verdicts_by_run` checks
it); the verdict is about a model trained at this scale, not about one training run.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from statistics import stdev

from motionlab.comparison import MIN_SEEDS, Run, RunDifferences, student_t
from motionlab.estimate import Estimate

FOLDER = ("book", "data", "training_seeds")


@dataclass(frozen=True)
class TrainingSpread:
    """Claim numbers measured on several training runs of the same models: ``values[key][run]``
    (:class:`Run`: a seed in a precision).

    ``data`` is the dataset key the numbers were measured on (a spread applies only to results on that data),
    ``measured`` one line per run: where and how it was measured; ``set_aside`` one line per recorded run left out
    because its models or evaluations are not the code's any more (:func:`read_spread`).
    """

    profile: str
    data: str
    values: dict[str, dict[Run, float]] = field(default_factory=dict)
    measured: tuple[str, ...] = ()
    set_aside: tuple[str, ...] = ()

    def runs(self, *keys: str) -> list[Run]:
        """The training runs on which every one of ``keys`` was measured (sorted by precision, then seed)."""
        common = set.intersection(*(set(self.values.get(k, {})) for k in keys)) if keys else set()
        return sorted(common)

    def difference(self, a: str, b: str) -> Estimate | None:
        """``a − b`` across the training runs both were measured on: the mean difference, and as the half-width
        ``t_{0.975, k−1} · sd`` the spread of *one* training run's difference around it (None below ``MIN_SEEDS``).
        Runs in two precisions pool: a shift between them counts as spread, as a reader's machine is another run."""
        runs = self.runs(a, b)
        if len(runs) < MIN_SEEDS:
            return None
        d = [self.values[a][r] - self.values[b][r] for r in runs]
        return Estimate(sum(d) / len(d), student_t(len(d)) * stdev(d), len(d))

    def other_runs(self, a: str, b: str, build: Run | None) -> RunDifferences | None:
        """``a − b`` on the recorded runs, leaving out ``build`` (the run this build repeats; None: a build that
        repeats none of them), for :meth:`RunDifferences.pooled` (None where fewer than ``MIN_SEEDS − 1`` remain)."""
        runs = [r for r in self.runs(a, b) if r != build]
        if len(runs) < MIN_SEEDS - 1:
            return None
        return RunDifferences(tuple(runs), tuple(self.values[a][r] - self.values[b][r] for r in runs))

    def mean_with(self, key: str, here: float, build: Run | None) -> tuple[float, int] | None:
        """``key`` averaged over the recorded runs other than ``build`` and this build's ``here``: ``(mean, n)``
        (None where fewer than ``MIN_SEEDS − 1`` other runs measured it). For rules without an interval."""
        others = [v for r, v in self.values.get(key, {}).items() if r != build]
        if len(others) < MIN_SEEDS - 1:
            return None
        return (sum(others) + here) / (len(others) + 1), len(others) + 1

    def run_independent(self, key: str, value: float) -> bool:
        """Whether ``key`` is a number no training run moves, and ``value`` is it: the same on every recorded run
        (ground truth on the study's data, whose note names no model's data)."""
        values = list(self.values.get(key, {}).values())
        return len(values) >= MIN_SEEDS and all(math.isclose(v, value, rel_tol=1e-6, abs_tol=1e-12) for v in values)

    def applies_to(self, note: str | None) -> bool:
        """Whether a recorded result (by its note, which names the data as ``data <key>``) is on this spread's data."""
        return bool(note) and f"data {self.data}" in note

    def moves(self, key: str, note: str | None) -> bool:
        """Whether another training run moves the recorded number ``key`` (its result's ``note``): the study measured
        it, on that result's data (a real-data chapter's number, or ground truth whose note names no data, does not)."""
        return key in self.values and self.applies_to(note)


def find_folder(parts: Sequence[str], start: Path | None = None) -> Path | None:
    """A folder of the repository (e.g. ``book/data/training_seeds``), from the working directory upwards, then from
    this file upwards (an editable install); None where there is none (an installed wheel has no ``book/``)."""
    here = (start or Path.cwd()).resolve()
    for base in (here, *here.parents, *Path(__file__).resolve().parents):
        candidate = base.joinpath(*parts)
        if candidate.is_dir():
            return candidate
    return None


def embedded_data_folder(parts: Sequence[str]) -> Path | None:
    """``<repository>/<parts>/embedded-v<N>``, a study's folder for the current version of the embedded data (None
    where the repository has no ``parts`` folder, e.g. an installed wheel)."""
    from motionlab.data.embedded.generator import VERSION

    root = find_folder(parts)
    return None if root is None else root / f"embedded-v{VERSION}"


def study_folder(parts: Sequence[str], folder: str | Path | None = None) -> Path | None:
    """Where a study's records are read from: ``folder`` where given, else :func:`embedded_data_folder` of ``parts``
    (None outside the repository)."""
    return Path(folder) if folder is not None else embedded_data_folder(parts)


def read_current(
    folder: Path, profile: str, changes: Callable[[dict, str], list | None], study: str | None = None
) -> tuple[list[dict], list[str]]:
    """The records of ``profile`` in ``folder`` (of ``study``, where given) that measured what the code builds now,
    and one line per record set aside because it did not: ``changes(record, profile)`` lists what differs from the
    code's configs ([]: nothing; None: the record kept no configs). A model trained or scored otherwise is another
    model. A folder whose every record is set aside warns once: it reads as if nothing were recorded."""
    from motionlab.evaluation.studies import changes_phrase

    records, set_aside = [], []
    for path in sorted(folder.glob("*.json")):
        record = json.loads(path.read_text())
        if record.get("profile") != profile or (study is not None and record.get("study") != study):
            continue
        found = changes(record, profile)
        if found:
            set_aside.append(f"{path.name} (commit {record.get('commit', '?')}): {changes_phrase(found)}")
        elif found is None:
            set_aside.append(f"{path.name} (commit {record.get('commit', '?')}): recorded without its configs")
        else:
            records.append(record)
    if set_aside and not records:
        warnings.warn(f"every record in {folder} was set aside:\n" + "\n".join(set_aside), stacklevel=3)
    return records, set_aside


def read_spread(files: Iterable[Path], profile: str) -> TrainingSpread | None:
    """The spread in ``files`` (the study's ``<study>-<profile>-<precision>-seed<k>.json``) for ``profile``; None if
    none match.

    Every file must be on the same data; a run (seed and precision) recorded twice (two studies of one chain) is an
    error. A run whose recorded configs (``"configs"``) differ from those the code builds now
    (:func:`motionlab.evaluation.studies.study_configs`) measured other models or another evaluation: it is set aside
    (``TrainingSpread.set_aside`` says which and why), so a study recorded before a change never joins a verdict.
    """
    values: dict[str, dict[Run, float]] = {}
    data, measured, set_aside = None, [], []
    current: dict[str, dict] = {}  # study -> the code's configs, built once
    for path in sorted(files):
        record = json.loads(Path(path).read_text())
        if record.get("profile") != profile:
            continue
        if data is not None and record["data"] != data:
            raise ValueError(f"{path} was measured on {record['data']}, the others on {data}")
        data, study = record["data"], record["study"]
        run = Run(record["precision"], int(record["training_seed"]))
        if (stale := stale_reason(record, current, profile)) is not None:
            set_aside.append(f"{study} {run} ({Path(path).name}, commit {record['commit']}): {stale}")
            continue
        for key, value in record["values"].items():
            per_run = values.setdefault(key if "/" in key else f"{study}/{key}", {})
            if run in per_run:
                raise ValueError(f"{path}: training {run} of {study}/{key} is recorded twice")
            per_run[run] = float(value)
        measured.append(f"{study} {run}: {record['cpu']}, {record['precision']}, commit {record['commit']}")
    if data is None:
        return None
    return TrainingSpread(profile, data, values, tuple(measured), tuple(set_aside))


def stale_reason(record: dict, current: dict[str, dict], profile: str) -> str | None:
    """Why ``record``'s run measured something other than the code's models and evaluations, or None if it did not.
    ``current`` caches the code's configs per study across calls (pass one dict for a folder of records)."""
    from motionlab.evaluation.studies import STUDIES, changes_phrase, config_changes, study_configs

    study = record["study"]
    if study not in STUDIES:
        return f"{study!r} is none of the code's studies {STUDIES}"
    if "configs" not in record:
        return "recorded without the configs it was measured with"
    if study not in current:
        current[study] = study_configs(study, profile)
    changes = config_changes(record["configs"], current[study])
    return changes_phrase(changes) if changes else None


def load_spread(profile: str, folder: str | Path | None = None, data: str | None = None) -> TrainingSpread | None:
    """The recorded training-seed spread of ``profile``'s models on the embedded data (None where none was measured,
    or, given ``data``, a dataset key, where it was measured on other data, or where every recorded run was set aside:
    then a warning lists them).

    ``folder`` defaults to the repository's ``book/data/training_seeds/embedded-v<N>`` of the current embedded data.
    """
    folder = study_folder(FOLDER, folder)
    if folder is None:
        return None
    spread = read_spread(folder.glob("*.json"), profile)
    if spread is None or (data is not None and spread.data != data):
        return None
    if not spread.measured:  # every run measured other models: as if none were recorded, said once
        warnings.warn(
            "every recorded run of the training-seed study was set aside, so the verdicts read this build alone:\n"
            + "\n".join(spread.set_aside),
            stacklevel=2,
        )
        return None
    return spread
