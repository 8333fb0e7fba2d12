"""Retraining and the verdicts: how far another training run moves each comparison the claims table judges.

The training-seed study (``experiments/training_seeds.py``, read by :class:`motionlab.report.spread.TrainingSpread`)
trained the claims' models again with other seeds and in two precisions. This module lays one question of it out as a
figure: on each recorded run, does the comparison point the way the mean over the runs points?
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from motionlab.report.claims import CLAIMS, Claim
from motionlab.report.quantities import quantity
from motionlab.report.spread import TrainingSpread


def run_differences(spread: TrainingSpread, claims: Sequence[Claim] = CLAIMS) -> dict[str, dict[str, list[float]]]:
    """``{comparison: {precision: [a − b on each run of it]}}`` for every pair of ``claims`` the study measured on at
    least two runs, in claim order; a comparison is named by its quantity and the two conditions."""
    out: dict[str, dict[str, list[float]]] = {}
    for claim in claims:
        for a, b in getattr(claim.rule, "pairs", ()):
            runs = spread.runs(a, b)
            if len(runs) < 2:
                continue
            (name, condition_a), (_, condition_b) = quantity(a), quantity(b)
            by_precision = out.setdefault(f"{name}: {condition_a} − {condition_b}", {})
            for run in runs:
                by_precision.setdefault(run.precision, []).append(spread.values[a][run] - spread.values[b][run])
    return out


def plot_run_differences(spread: TrainingSpread, claims: Sequence[Claim] = CLAIMS, ax=None, clip: float = 3.0):
    """Each training run's ``a − b`` in units of the mean over the runs, one row per comparison: the mean sits at
    +1, and a run left of 0 reads the other direction. Values beyond ±``clip`` are drawn at the edge. Returns the axes.
    """
    import matplotlib.pyplot as plt

    rows = run_differences(spread, claims)
    if not rows:
        raise ValueError("the training-seed study measured none of these claims' comparisons on two runs or more")
    if ax is None:
        _, ax = plt.subplots(figsize=(7.4, 0.28 * len(rows) + 1.0))
    markers = {"bf16": "o", "fp32": "s"}
    for y, by_precision in enumerate(rows.values()):
        mean = float(np.mean([d for values in by_precision.values() for d in values]))
        for k, (precision, values) in enumerate(sorted(by_precision.items())):
            scaled = np.clip(np.asarray(values) / mean if mean else np.zeros(len(values)), -clip, clip)
            offsets = y + (k - 0.5) * 0.25
            ax.plot(
                scaled,
                np.full(len(scaled), offsets),
                markers.get(precision, "^"),
                ms=4,
                color=f"C{k}",
                alpha=0.8,
                label=precision if y == 0 else None,
            )
    ax.axvline(0, color="k", lw=0.8)
    ax.axvline(1, color="gray", ls=":", lw=0.8)
    ax.set_yticks(range(len(rows)), list(rows), fontsize=7)
    ax.invert_yaxis()
    ax.set_xlim(-clip - 0.2, clip + 0.2)
    ax.set_xlabel("one run's a − b ÷ the mean over the runs (below 0: the other direction)")
    ax.legend(fontsize=8, loc="lower right")
    return ax


def flipping(spread: TrainingSpread, claims: Sequence[Claim] = CLAIMS) -> list[str]:
    """The comparisons on which at least one recorded run points the other way from the mean over the runs."""
    flips = []
    for label, by_precision in run_differences(spread, claims).items():
        values = [d for v in by_precision.values() for d in v]
        mean = float(np.mean(values))
        if any(np.sign(d) != np.sign(mean) for d in values):
            flips.append(label)
    return flips
