"""The evaluation table: rows × metrics of :class:`~motionlab.estimate.Estimate`, as Markdown and JSON (recorded for
the claims table by :func:`motionlab.results.record_table`)."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from motionlab.estimate import Estimate

if TYPE_CHECKING:
    from motionlab.comparison import RunDifferences

TASKS = ("reconstruction", "t2m", "multi")
SPLITS = ("train", "val", "test")
R_PRECISION_BATCH = 32  # the T2M protocol ranks each text among 32 motions

RECONSTRUCTION_METRICS = ("fid", "mpjpe_mm", "sjpe", "noise_sjpe", "static_sjpe", "sjpe_ratio")
T2M_METRICS = ("top1", "top2", "top3", "fid", "mm_dist", "diversity", "multimodality")
MULTI_METRICS = ("r_top3", "fid", "mm_dist", "diversity", "transition_fid", "transition_diversity", "jerk")

# Column headers as the papers print them (↓ lower is better, ↑ higher, → closer to the real data).
METRIC_LABELS = {
    "fid": "FID ↓",
    "mpjpe_mm": "MPJPE (mm) ↓",
    "sjpe": "sJPE ↓",
    "noise_sjpe": "Noise sJPE ↓",
    "static_sjpe": "Static sJPE ↓",
    "sjpe_ratio": "sJPE (ratio, paper scale) ↓",
    "noise_sjpe_ratio": "Noise sJPE (ratio) ↓",
    "static_sjpe_ratio": "Static sJPE (ratio) ↓",
    "top1": "R-Top1 ↑",
    "top2": "R-Top2 ↑",
    "top3": "R-Top3 ↑",
    "r_top3": "R-Top3 ↑",
    "mm_dist": "MM-Dist ↓",
    "diversity": "Diversity →",
    "multimodality": "MModality ↑",
    "transition_fid": "Transition FID ↓",
    "transition_diversity": "Transition Diversity →",
    "jerk": "Jerk →",
    "segment_jerk": "Jerk inside the actions →",
    "cut_minus_inside": "cut − inside",
    # the options' columns: DisCoRD Table E and the reconstruction extras, the sampled codes of Table 3
    "joint_jerk": "joint jerk (m/s³) →",
    "noise_sjpe_boundary_share": "Noise sJPE share on token boundaries",
    "seconds": "time per batch (s) ↓",
    "gflops": "GFLOPs per batch ↓",
    "hist_tv": "code-histogram TV to real ↓",
    "repeat_rate": "adjacent repeats",
}


def metric_label(metric: str) -> str:
    """A column's header: :data:`METRIC_LABELS`, the Noise sJPE of token phase ``p`` (``noise_sjpe_phase<p>``), or
    the metric's own name."""
    if metric in METRIC_LABELS:
        return METRIC_LABELS[metric]
    if metric.startswith("noise_sjpe_phase") and metric[len("noise_sjpe_phase") :].isdigit():
        p = int(metric[len("noise_sjpe_phase") :])
        return "Noise sJPE on token boundaries ↓" if p == 0 else f"Noise sJPE, phase {p} ↓"
    return metric


# ----------------------------------------------------------------------------------------------- the table


@dataclass
class EvaluationTable:
    """One evaluation: ``rows[row][metric]`` is an :class:`Estimate` (mean, 95 % half-width, n runs).

    ``metrics`` orders the columns; a row may lack some (printed "–"). Rows in ``deterministic`` come from
    one run of a deterministic computation: their half-width is 0 by construction, not by measurement.
    """

    task: str
    profile: str
    data: str  # the dataset's key (folder name + normalisation digest)
    split: str
    repeats: int
    seed: int
    config: dict[str, Any]
    counts: dict[str, int]  # what was evaluated, e.g. {"clips": 42} or {"instances": 3, "actions": 4}
    metrics: tuple[str, ...]
    rows: dict[str, dict[str, Estimate]]
    deterministic: tuple[str, ...] = ()
    notes: list[str] = field(default_factory=list)
    precision: str = "fp32"  # what the models were trained and sampled in (motionlab.precision); metrics are fp32
    # Per row and metric, the values behind an estimate in an order shared across rows (repeat by repeat, or boundary
    # by boundary), so that two rows measured on the same seeds and instances pair up (:meth:`paired`).
    samples: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    # Per row and metric, each test clip's value (averaged over the row's runs), in one clip order for every row, for
    # the metrics that are means over clips; ``clip_weights[metric]`` where the metric pools frames instead (MPJPE).
    # What :meth:`paired_clips` resamples. Like ``samples``, not written to JSON.
    clip_values: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    clip_weights: dict[str, list[float]] = field(default_factory=dict)

    def header(self) -> str:
        """One line: task, profile, precision, dataset key, what was evaluated, repeats and seed."""
        counts = ", ".join(f"{n} {what}" for what, n in self.counts.items())
        repeats = f"{self.repeats} repeat{'s' if self.repeats != 1 else ''}"
        return (
            f"evaluate {self.task}: profile {self.profile}, {self.precision}, data {self.data}, split "
            f"{self.split}, {counts}, {repeats}, seed {self.seed}"
        )

    def to_markdown(self, digits: int = 3) -> str:
        """A Markdown table, ``mean ± half-width`` per cell (the mean alone in deterministic or one-run rows)."""
        lines = [
            "| | " + " | ".join(metric_label(m) for m in self.metrics) + " |",
            "|---|" + "---:|" * len(self.metrics),
        ]
        for name, row in self.rows.items():
            fixed = name in self.deterministic
            cells = [_cell(row[m], digits, fixed) if m in row else "–" for m in self.metrics]
            label = f"{name} (deterministic)" if fixed else name
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
        interval = "± = 95% interval of the mean, Student's t with n − 1 degrees of freedom."
        return "\n".join(lines + [f"\n{note}" for note in [*self.notes, interval]])

    def __str__(self) -> str:
        """What ``print(table)`` shows: the :meth:`header` line, then the Markdown table (the dataclass's ``repr``
        stays the full record)."""
        return f"{self.header()}\n{self.to_markdown()}"

    def _repr_markdown_(self) -> str:
        """Jupyter shows the table itself, rendered."""
        return self.to_markdown()

    # ------------------------------------------------------------------ what a chapter does with a table

    def _row(self, row: str) -> dict[str, Estimate]:
        if row not in self.rows:
            raise KeyError(f"no row {row!r} in this {self.task} table; rows: {list(self.rows)}")
        return self.rows[row]

    def estimate(self, row: str, metric: str) -> Estimate:
        """The cell ``rows[row][metric]``; a missing row or metric is named with what the table has."""
        cells = self._row(row)
        if metric not in cells:
            raise KeyError(f"row {row!r} has no metric {metric!r}; it has {list(cells)}")
        return cells[metric]

    def select(self, *rows: str, metrics: Sequence[str] | None = None, notes: bool = True) -> EvaluationTable:
        """The same table with only ``rows`` (in that order) and, if given, only ``metrics``; ``notes=False`` drops
        the notes under it (for a page that has shown them once already)."""
        chosen = {name: dict(self._row(name)) for name in rows}
        columns = tuple(self.metrics if metrics is None else metrics)
        kept = tuple(r for r in self.deterministic if r in rows)
        return replace(self, rows=chosen, metrics=columns, deterministic=kept, notes=self.notes if notes else [])

    def with_rows(
        self, rows: Mapping[str, Mapping[str, Estimate]], deterministic: Sequence[str] = ()
    ) -> EvaluationTable:
        """The table with ``rows`` added (or replaced) after the existing ones; e.g. another model's rows measured
        on the same instances. Metrics that only the new rows have become new columns."""
        merged = {name: dict(cells) for name, cells in self.rows.items()}
        merged.update({name: dict(cells) for name, cells in rows.items()})
        metrics = list(self.metrics) + [m for cells in rows.values() for m in cells if m not in self.metrics]
        fixed = tuple(dict.fromkeys([*self.deterministic, *deterministic]))
        return replace(self, rows=merged, metrics=tuple(dict.fromkeys(metrics)), deterministic=fixed)

    def compare(
        self,
        row_a: str,
        row_b: str,
        metric: str,
        name_a: str | None = None,
        name_b: str | None = None,
        *,
        training: RunDifferences | None = None,
    ):
        """``row_a`` against ``row_b`` on ``metric`` by the one rule (:func:`motionlab.comparison.compare`);
        ``training``: the difference on the other recorded training runs, where measured
        (:meth:`motionlab.report.TrainingSpread.other_runs`): the verdict is then their mean with this table's."""
        from motionlab.comparison import compare

        quantity = metric_label(metric).rstrip(" ↓↑→")
        return compare(
            self.estimate(row_a, metric),
            self.estimate(row_b, metric),
            name_a or row_a,
            name_b or row_b,
            quantity=quantity,
            training=training,
        )

    def paired(self, row_a: str, row_b: str, metric: str) -> Estimate:
        """``row_a − row_b`` on ``metric``, paired sample by sample (same seeds, same instances): the interval of a
        paired difference, which leaves out the noise the two rows share. Needs both rows' :attr:`samples`."""
        from motionlab.estimate import mean_ci

        missing = [r for r in (row_a, row_b) if metric not in self.samples.get(r, {})]
        if missing:
            raise KeyError(f"no {metric!r} samples for {missing}; rows with samples: {list(self.samples)}")
        a, b = (np.asarray(self.samples[r][metric], dtype=float) for r in (row_a, row_b))
        if a.shape != b.shape:
            raise ValueError(f"{row_a!r} has {a.size} {metric} samples and {row_b!r} {b.size}: they do not pair up")
        d = a - b
        return mean_ci(d[np.isfinite(d)])

    def paired_clips(self, row_a: str, row_b: str, metric: str, *, resamples: int | None = None) -> Estimate:
        """``row_a − row_b`` on ``metric`` with a paired bootstrap over the test clips (seeded by the table's seed):
        the interval a deterministic decoder's row lacks, the variance of drawing this test set. Needs both rows'
        :attr:`clip_values` (reconstruction tables have them for sJPE, its parts and MPJPE)."""
        from motionlab.estimate import BOOTSTRAP_RESAMPLES, paired_bootstrap

        missing = [r for r in (row_a, row_b) if metric not in self.clip_values.get(r, {})]
        if missing:
            raise KeyError(f"no per-clip {metric!r} for {missing}; rows with per-clip values: {list(self.clip_values)}")
        a, b = (self.clip_values[r][metric] for r in (row_a, row_b))
        unit = self.estimate(row_a, metric).unit if metric in self.rows.get(row_a, {}) else None
        return paired_bootstrap(
            a,
            b,
            self.clip_weights.get(metric),
            resamples=resamples or BOOTSTRAP_RESAMPLES,
            seed=self.seed,
            unit=unit,
        )

    def joined(self, other: EvaluationTable, prefix: str = "") -> EvaluationTable:
        """This table with ``other``'s rows added after its own, named ``prefix + row``, with their :attr:`samples`
        (which :meth:`with_rows` cannot carry): e.g. another model's or decoder's rows measured on the same data,
        split and seed, so that :meth:`paired` pairs rows across the two evaluations. ``other``'s notes that this
        table lacks are kept, introduced by the prefix."""
        mine, theirs = (self.task, self.data, self.split, self.seed), (other.task, other.data, other.split, other.seed)
        if mine != theirs:
            raise ValueError(f"only tables of the same task, data, split and seed join: {mine} and {theirs}")
        renamed = {prefix + name: cells for name, cells in other.rows.items()}
        clash = [name for name in renamed if name in self.rows]
        if clash:
            raise ValueError(f"rows {clash} are in both tables; pass a prefix")
        table = self.with_rows(renamed, deterministic=[prefix + name for name in other.deterministic])
        samples = {
            **self.samples,
            **{prefix + name: dict(other.samples[name]) for name in other.rows if name in other.samples},
        }
        clips = {
            **self.clip_values,
            **{prefix + name: dict(other.clip_values[name]) for name in other.rows if name in other.clip_values},
        }
        lead = f"{prefix.strip(' :')} rows: " if prefix.strip(" :") else ""
        notes = self.notes + [lead + note for note in other.notes if note not in self.notes]
        return replace(table, samples=samples, clip_values=clips, notes=notes)

    def to_json_dict(self) -> dict[str, Any]:
        """Plain JSON types; a non-finite number becomes ``null`` (JSON has no NaN)."""
        rows = {
            name: {m: {"mean": _finite(e.mean), "ci95": _finite(e.half_width), "n": e.n} for m, e in row.items()}
            for name, row in self.rows.items()
        }
        return {
            "task": self.task,
            "profile": self.profile,
            "precision": self.precision,
            "data": self.data,
            "split": self.split,
            "repeats": self.repeats,
            "seed": self.seed,
            "config": self.config,
            "counts": self.counts,
            "metrics": list(self.metrics),
            "deterministic": list(self.deterministic),
            "notes": self.notes,
            "rows": rows,
        }

    @classmethod
    def from_json_dict(cls, record: Mapping[str, Any]) -> EvaluationTable:
        """The table :meth:`to_json_dict` wrote (its per-sample values are not stored: :meth:`paired` needs the
        table as computed); a ``null`` number reads back as NaN."""

        def number(x: float | None) -> float:
            return math.nan if x is None else float(x)

        rows = {
            name: {m: Estimate(number(c["mean"]), number(c["ci95"]), int(c["n"])) for m, c in row.items()}
            for name, row in record["rows"].items()
        }
        fields = ("task", "profile", "data", "split", "repeats", "seed", "config", "counts")
        return cls(
            **{name: record[name] for name in fields},
            metrics=tuple(record["metrics"]),
            rows=rows,
            deterministic=tuple(record.get("deterministic", ())),
            notes=list(record.get("notes", [])),
            precision=record.get("precision", "fp32"),
        )


def _cell(e: Estimate, digits: int, fixed: bool) -> str:
    # one run has no spread to report: print its value alone rather than a "± 0" that looks measured
    return format(Estimate(e.mean) if fixed else e, f".{digits}f")


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def check_json_path(path: str | Path, force: bool = False) -> Path:
    """Validate an output path *before* the work: its folder exists, and it is new unless ``force``."""
    path = Path(path)
    if path.suffix != ".json":
        raise ValueError(f"the JSON output must end in .json, got {str(path)!r}")
    if not path.parent.is_dir():
        raise ValueError(f"folder {str(path.parent)!r} of the JSON output does not exist")
    if path.exists() and not force:
        raise ValueError(f"{path} exists; pass force=True to replace it")
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a file")
    return path


def write_json(table: EvaluationTable, path: str | Path, force: bool = False) -> Path:
    """Write ``table.to_json_dict()`` to ``path`` atomically: a reader sees no file or the whole file."""
    from motionlab.io.common import write_text_atomic

    path = check_json_path(path, force)
    text = json.dumps(table.to_json_dict(), indent=1, ensure_ascii=False, allow_nan=False)
    return write_text_atomic(path, text + "\n")
