"""Reading a DisCoRD decoder sweep: which parameterisation, sampling and budget give the smoothest decoder.

``experiments/discord_sweep.py`` trains each *variant* (a set of :class:`~motionlab.flow.DisCoRDConfig`
overrides) under one wall-clock budget and writes ``<variant>.json``: the feed-forward and ground-truth
scores on the validation clips, then, at fractions of the run (its *checkpoints*), the reconstruction scores of
the EMA weights under several *samplings* (start-noise temperature, time grid, last step), one run per
sampling seed. These helpers turn that folder into tables and curves; they compute nothing new.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from motionlab.metrics.protocol import Estimate


def load_sweep(folder: str | Path) -> dict[str, dict[str, Any]]:
    """Every ``<variant>.json`` of ``folder``, by variant name (sorted); raises if there is none."""
    folder = Path(folder)
    found = {p.stem: json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))}
    if not found:
        raise FileNotFoundError(f"no sweep results (*.json) in {folder}")
    return found


def estimate(result: dict[str, Any], sampling: str, metric: str, checkpoint: int = -1) -> Estimate:
    """Mean and 95% interval (Student's t) of ``metric`` over the sampling seeds of one checkpoint."""
    runs = result["checkpoints"][checkpoint]["samplings"][sampling]["runs"]
    return Estimate.from_values([run[metric] for run in runs])


def best_setting(sweep: dict[str, dict[str, Any]], metric: str = "sjpe") -> tuple[str, str]:
    """The (variant, sampling) whose last checkpoint has the lowest mean ``metric``."""
    candidates = [(estimate(r, s, metric).mean, v, s) for v, r in sweep.items()
                  for s in r["checkpoints"][-1]["samplings"]]  # fmt: skip
    _, variant, sampling = min(candidates)
    return variant, sampling


def budget_curve(result: dict[str, Any], sampling: str, metric: str = "sjpe") -> tuple[np.ndarray, np.ndarray]:
    """``(training seconds, mean metric)`` at each checkpoint of a variant for one sampling."""
    seconds, values = [], []
    for point in result["checkpoints"]:
        runs = point["samplings"].get(sampling)
        if runs is not None:
            seconds.append(point["train_seconds"])
            values.append(np.mean([run[metric] for run in runs["runs"]]))
    return np.array(seconds), np.array(values)


def sweep_rows(sweep: dict[str, dict[str, Any]], samplings: Sequence[str] | None = None,
               metrics: Sequence[str] = ("sjpe", "noise_sjpe", "static_sjpe", "fid", "joint_jerk")
               ) -> list[dict[str, Any]]:  # fmt: skip
    """One row per (variant, sampling) at the last checkpoint: steps, seconds, seed spread, metric estimates."""
    rows = []
    for variant, result in sweep.items():
        last = result["checkpoints"][-1]
        for sampling, scored in last["samplings"].items():
            if samplings is not None and sampling not in samplings:
                continue
            row = {"variant": variant, "sampling": sampling, "steps": last["step"],
                   "train_seconds": last["train_seconds"], "seed_rms": scored.get("seed_rms", float("nan"))}
            row.update({m: estimate(result, sampling, m) for m in metrics})
            rows.append(row)
    return rows


__all__ = ["best_setting", "budget_curve", "estimate", "load_sweep", "sweep_rows"]
