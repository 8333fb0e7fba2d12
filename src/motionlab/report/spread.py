"""How far retraining moves a claim's numbers: the between-training-run spread the claims table adds to its intervals.

A chapter's number comes from one trained model. Its interval (sampling seeds, test clips) says how well that model
was measured, not how far another training run — another seed, another CPU, another precision — would land. A
verdict judged on it alone can flip between two machines. The training-seed study (``experiments/training_seeds.py``)
trains the same models again with other seeds, on machines of more than one precision, and records every claim number
per run under ``book/data/training_seeds/embedded-v<N>/``; :class:`TrainingSpread` reads those files.

The rule (stated on chapter 99): for a comparison of ``a`` with ``b`` whose numbers were measured on ``k >= 3``
training runs (seeds, in each precision recorded), the per-run differences ``d_s = a_s − b_s`` give the spread of
one training run's difference, ``t_{0.975, k−1} · sd(d)``; the verdict's 95% interval of ``a − b`` adds it in
quadrature to the measurement's (:class:`motionlab.report.Comparison`'s ``training``). A difference that retraining
alone can produce reads "inconclusive"; :func:`motionlab.report.render.verdicts_by_run` checks how far that makes the
verdicts agree between machines.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from motionlab.estimate import Estimate

MIN_SEEDS = 3  # fewer seeds give no usable spread (t with one degree of freedom is 12.7)
FOLDER = ("book", "data", "training_seeds")


class Run(NamedTuple):
    """One training run of a study's models: the precision it was trained in and its seed. Seed 0 in bf16 on one CPU
    and seed 0 in fp32 on another are two runs (the book's model on each machine), and both join the spread."""

    precision: str
    seed: int

    def __str__(self) -> str:
        return f"seed {self.seed} ({self.precision})"


@dataclass(frozen=True)
class TrainingSpread:
    """Claim numbers measured on several training runs of the same models: ``values[key][run]``
    (:class:`Run`: a seed in a precision).

    ``data`` is the dataset key the numbers were measured on (a spread applies only to results on that data),
    ``measured`` one line per run: where and how it was measured.
    """

    profile: str
    data: str
    values: dict[str, dict[Run, float]] = field(default_factory=dict)
    measured: tuple[str, ...] = ()

    def runs(self, *keys: str) -> list[Run]:
        """The training runs on which every one of ``keys`` was measured (sorted by precision, then seed)."""
        common = set.intersection(*(set(self.values.get(k, {})) for k in keys)) if keys else set()
        return sorted(common)

    def difference(self, a: str, b: str) -> Estimate | None:
        """``a − b`` across the training runs both were measured on: the mean difference, and as the half-width
        ``t_{0.975, k−1} · sd`` the spread of *one* training run's difference around it (None below ``MIN_SEEDS``).
        Runs in two precisions pool: a shift between them counts as spread, as a reader's machine is another run."""
        from scipy.special import stdtrit

        runs = self.runs(a, b)
        if len(runs) < MIN_SEEDS:
            return None
        d = [self.values[a][r] - self.values[b][r] for r in runs]
        mean = sum(d) / len(d)
        sd = math.sqrt(sum((x - mean) ** 2 for x in d) / (len(d) - 1))
        return Estimate(mean, float(stdtrit(len(d) - 1, 0.975)) * sd, len(d))

    def applies_to(self, note: str | None) -> bool:
        """Whether a recorded result (by its note, which names the data as ``data <key>``) is on this spread's data."""
        return bool(note) and f"data {self.data}" in note


def find_folder(parts: Sequence[str], start: Path | None = None) -> Path | None:
    """A folder of the repository (e.g. ``book/data/training_seeds``), from the working directory upwards, then from
    this file upwards (an editable install); None where there is none (an installed wheel has no ``book/``)."""
    here = (start or Path.cwd()).resolve()
    for base in (here, *here.parents, *Path(__file__).resolve().parents):
        candidate = base.joinpath(*parts)
        if candidate.is_dir():
            return candidate
    return None


def read_spread(files: Iterable[Path], profile: str) -> TrainingSpread | None:
    """The spread in ``files`` (the study's ``<study>-<profile>-<precision>-seed<k>.json``) for ``profile``; None if
    none match.

    Every file must be on the same data; a run (seed and precision) recorded twice (two studies of one chain) is an
    error.
    """
    values: dict[str, dict[Run, float]] = {}
    data, measured = None, []
    for path in sorted(files):
        record = json.loads(Path(path).read_text())
        if record.get("profile") != profile:
            continue
        if data is not None and record["data"] != data:
            raise ValueError(f"{path} was measured on {record['data']}, the others on {data}")
        data, study = record["data"], record["study"]
        run = Run(record["precision"], int(record["training_seed"]))
        for key, value in record["values"].items():
            per_run = values.setdefault(key if "/" in key else f"{study}/{key}", {})
            if run in per_run:
                raise ValueError(f"{path}: training {run} of {study}/{key} is recorded twice")
            per_run[run] = float(value)
        measured.append(f"{study} {run}: {record['cpu']}, {record['precision']}, commit {record['commit']}")
    if data is None:
        return None
    return TrainingSpread(profile, data, values, tuple(measured))


def load_spread(profile: str, folder: str | Path | None = None, data: str | None = None) -> TrainingSpread | None:
    """The recorded training-seed spread of ``profile``'s models on the embedded data (None where none was measured,
    or, given ``data``, a dataset key, where it was measured on other data).

    ``folder`` defaults to the repository's ``book/data/training_seeds/embedded-v<N>`` of the current embedded data.
    """
    if folder is None:
        from motionlab.data.embedded.generator import VERSION

        root = find_folder(FOLDER)
        if root is None:
            return None
        folder = root / f"embedded-v{VERSION}"
    spread = read_spread(Path(folder).glob("*.json"), profile)
    return None if spread is None or (data is not None and spread.data != data) else spread
