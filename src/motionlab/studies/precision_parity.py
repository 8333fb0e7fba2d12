"""bf16 against fp32, measured: the recorded parity runs (``experiments/precision_parity.py``) as tables.

Each run trained the laptop models in one precision on the same data and scored them with the book's evaluations
(one ``<precision>.json`` per run, in ``book/data/precision_parity``). Chapter 98 shows:

- :func:`training_times`: each model's training time (CPU seconds of its ``motionlab train`` process, both runs
  side by side on one 2-core machine) and the fp32/bf16 ratio;
- :func:`quality_rows`: every quality number of both runs, mean ± 95% half-width, and the book's one verdict on
  bf16 against fp32 (:func:`motionlab.comparison.compare`: the 95% interval of the difference excludes 0, or the two
  are not distinguishable). A deterministic row (one decode, no sampling noise) has no interval; there the relative
  difference is shown instead, and it contains the training run's own noise (one training seed per precision).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from motionlab.comparison import SAME, compare
from motionlab.estimate import Estimate

PRECISIONS = ("fp32", "bf16")

# (task, row selector, metric, what it measures): the numbers the parity table compares
QUALITY = (
    ("reconstruction", "decoder", "mpjpe_mm", "RVQ tokenizer: reconstruction MPJPE (mm)"),
    ("reconstruction", "decoder", "fid", "RVQ tokenizer: reconstruction FID"),
    ("reconstruction", "DisCoRD", "sjpe", "DisCoRD flow decoder: sJPE"),
    ("reconstruction", "DisCoRD", "fid", "DisCoRD flow decoder: reconstruction FID"),
    ("t2m", "Discrete diffusion", "fid", "diffusion model: text-to-motion FID"),
    ("t2m", "Discrete diffusion", "top1", "diffusion model: R-precision top 1"),
    ("t2m", "Discrete diffusion", "top3", "diffusion model: R-precision top 3"),
)


@dataclass(frozen=True)
class ParityRow:
    """One quantity in both precisions; a deterministic side is an :class:`Estimate` with ``n == 1``."""

    what: str
    fp32: Estimate
    bf16: Estimate

    @property
    def has_interval(self) -> bool:
        """Both sides were repeated (a deterministic row has one value per precision)."""
        return self.fp32.n > 1 and self.bf16.n > 1

    @property
    def verdict(self) -> str | None:
        """bf16 against fp32 by the one rule: ``"lower"``, ``"higher"`` or ``"not distinguishable"``; None
        without an interval (a deterministic row)."""
        if not self.has_interval:
            return None
        return compare(self.bf16, self.fp32, "bf16", "fp32", quantity=self.what).verdict

    @property
    def relative_difference(self) -> float:
        """``(bf16 − fp32) / |fp32|``."""
        return (self.bf16.mean - self.fp32.mean) / max(abs(self.fp32.mean), 1e-12)


def load_runs(folder: str | Path) -> dict[str, dict]:
    """``{"fp32": record, "bf16": record}`` from ``folder``; a missing or unreadable run is named in the error."""
    folder = Path(folder)
    runs = {}
    for precision in PRECISIONS:
        path = folder / f"{precision}.json"
        if not path.is_file():
            raise FileNotFoundError(f"no {precision} parity run at {path}: run experiments/precision_parity.py")
        runs[precision] = json.loads(path.read_text())
    return runs


def training_times(runs: dict[str, dict]) -> list[tuple[str, float, float, float]]:
    """``(model, fp32 CPU s, bf16 CPU s, fp32 / bf16)`` for every model both runs trained."""
    fp32, bf16 = runs["fp32"]["training"], runs["bf16"]["training"]
    return [
        (m, fp32[m]["cpu_seconds"], bf16[m]["cpu_seconds"], fp32[m]["cpu_seconds"] / bf16[m]["cpu_seconds"])
        for m in fp32
        if m in bf16
    ]


def _estimate(record: dict, task: str, row_part: str, metric: str) -> Estimate:
    table = record[task]["table"]
    rows = [name for name in table["rows"] if row_part in name]
    if len(rows) != 1:
        raise ValueError(f"expected one {task} row containing {row_part!r}, found {rows}")
    cell = table["rows"][rows[0]][metric]
    if rows[0] in table.get("deterministic", []) or cell["n"] < 2:
        return Estimate(float(cell["mean"]))
    return Estimate(float(cell["mean"]), float(cell["ci95"]), int(cell["n"]))


def quality_rows(runs: dict[str, dict]) -> list[ParityRow]:
    """Every quality number of :data:`QUALITY` in both runs, plus the evaluator's retrieval when it was measured."""
    out = [
        ParityRow(what, _estimate(runs["fp32"], task, row, metric), _estimate(runs["bf16"], task, row, metric))
        for task, row, metric, what in QUALITY
    ]
    if all("evaluator_parity" in runs[p] for p in PRECISIONS):
        for key, label in (("top1", "top 1"), ("top3", "top 3")):
            values = [float(runs[p]["evaluator_parity"]["validation"][f"val_{key}"]) for p in PRECISIONS]
            what = f"evaluator trained in this precision: validation retrieval {label}"
            out.append(ParityRow(what, Estimate(values[0]), Estimate(values[1])))
    return out


def markdown_tables(runs: dict[str, dict]) -> str:
    """Both tables as Markdown, with the machine they were measured on."""

    def cell(value: Estimate) -> str:
        return f"{value:.3f}"  # "mean ± half-width" where repeated, the value alone where deterministic

    lines = [
        f"Measured on {runs['fp32']['cpu']} ({runs['fp32']['started']}), profile {runs['fp32']['profile']}, "
        "both runs side by side with one torch thread each.",
        "",
        "| model | fp32 CPU s | bf16 CPU s | speed-up |",
        "|---|---:|---:|---:|",
    ]
    lines += [f"| {m} | {a:.0f} | {b:.0f} | {r:.2f}× |" for m, a, b, r in training_times(runs)]

    def verdict(row: ParityRow) -> str:
        if row.verdict is None:
            return f"no interval; bf16 {row.relative_difference:+.1%}"
        if row.verdict == SAME:
            return "not distinguishable at 95%"
        return f"bf16 {row.verdict} ({row.relative_difference:+.1%})"

    lines += ["", "| quantity | fp32 | bf16 | bf16 against fp32 (95% interval of the difference) |"]
    lines += ["|---|---:|---:|:---:|"]
    lines += [f"| {r.what} | {cell(r.fp32)} | {cell(r.bf16)} | {verdict(r)} |" for r in quality_rows(runs)]
    return "\n".join(lines)


__all__ = ["QUALITY", "ParityRow", "load_runs", "markdown_tables", "quality_rows", "training_times"]
