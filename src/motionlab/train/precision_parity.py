"""bf16 against fp32, measured: the recorded parity runs (``experiments/precision_parity.py``) as tables.

Each run trained the laptop models in one precision on the same data and scored them with the book's evaluations
(one ``<precision>.json`` per run, in ``book/data/precision_parity``). Chapter 98 shows:

- :func:`training_times`: each model's training time (CPU seconds of its ``motionlab train`` process, both runs
  side by side on one 2-core machine) and the fp32/bf16 ratio;
- :func:`quality_rows`: every quality number of both runs, mean ± 95% half-width, and whether the two intervals
  overlap. A deterministic row (one decode, no sampling noise) has no interval; there the relative difference is
  shown instead, and it contains the training run's own noise (one training seed per precision).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

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
class Comparison:
    """One quantity in both precisions: ``(mean, half-width or None)`` each."""

    what: str
    fp32: tuple[float, float | None]
    bf16: tuple[float, float | None]

    @property
    def within_intervals(self) -> bool | None:
        """Whether the two 95% intervals overlap; None when a side has no interval (a deterministic row)."""
        (a, ha), (b, hb) = self.fp32, self.bf16
        if ha is None or hb is None:
            return None
        return abs(a - b) <= ha + hb

    @property
    def relative_difference(self) -> float:
        """``(bf16 − fp32) / |fp32|``."""
        return (self.bf16[0] - self.fp32[0]) / max(abs(self.fp32[0]), 1e-12)


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


def _estimate(record: dict, task: str, row_part: str, metric: str) -> tuple[float, float | None]:
    table = record[task]["table"]
    rows = [name for name in table["rows"] if row_part in name]
    if len(rows) != 1:
        raise ValueError(f"expected one {task} row containing {row_part!r}, found {rows}")
    cell = table["rows"][rows[0]][metric]
    fixed = rows[0] in table.get("deterministic", []) or cell["n"] < 2
    return float(cell["mean"]), None if fixed else float(cell["ci95"])


def quality_rows(runs: dict[str, dict]) -> list[Comparison]:
    """Every quality number of :data:`QUALITY` in both runs, plus the evaluator's retrieval when it was measured."""
    out = [
        Comparison(what, _estimate(runs["fp32"], task, row, metric), _estimate(runs["bf16"], task, row, metric))
        for task, row, metric, what in QUALITY
    ]
    if all("evaluator_parity" in runs[p] for p in PRECISIONS):
        for key, label in (("top1", "top 1"), ("top3", "top 3")):
            values = [float(runs[p]["evaluator_parity"]["validation"][f"val_{key}"]) for p in PRECISIONS]
            out.append(
                Comparison(
                    f"evaluator trained in this precision: validation retrieval {label}",
                    (values[0], None),
                    (values[1], None),
                )
            )
    return out


def markdown_tables(runs: dict[str, dict]) -> str:
    """Both tables as Markdown, with the machine they were measured on."""

    def cell(value: tuple[float, float | None]) -> str:
        mean, half = value
        return f"{mean:.3f}" if half is None else f"{mean:.3f} ± {half:.3f}"

    lines = [
        f"Measured on {runs['fp32']['cpu']} ({runs['fp32']['started']}), profile {runs['fp32']['profile']}, "
        "both runs side by side with one torch thread each.",
        "",
        "| model | fp32 CPU s | bf16 CPU s | speed-up |",
        "|---|---:|---:|---:|",
    ]
    lines += [f"| {m} | {a:.0f} | {b:.0f} | {r:.2f}× |" for m, a, b, r in training_times(runs)]

    def verdict(c: Comparison) -> str:
        if c.within_intervals is None:
            return f"no interval; bf16 {c.relative_difference:+.1%}"
        return "yes" if c.within_intervals else f"no ({c.relative_difference:+.1%})"

    lines += ["", "| quantity | fp32 | bf16 | within the 95% intervals |", "|---|---:|---:|:---:|"]
    lines += [f"| {c.what} | {cell(c.fp32)} | {cell(c.bf16)} | {verdict(c)} |" for c in quality_rows(runs)]
    return "\n".join(lines)


__all__ = ["Comparison", "QUALITY", "load_runs", "markdown_tables", "quality_rows", "training_times"]
