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

from motionlab.estimate import Estimate


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


def best_setting(
    sweep: dict[str, dict[str, Any]], metric: str = "sjpe", max_budget: float | None = None
) -> tuple[str, str]:
    """The (variant, sampling) whose last checkpoint has the lowest mean ``metric``, among the variants trained
    with a budget of at most ``max_budget`` seconds (all if ``None``)."""
    candidates = [
        (estimate(r, s, metric).mean, v, s)
        for v, r in sweep.items()
        if max_budget is None or r["budget_s"] <= max_budget
        for s in r["checkpoints"][-1]["samplings"]
    ]
    if not candidates:
        raise ValueError(f"no variant was trained within a budget of {max_budget} s")
    _, variant, sampling = min(candidates)
    return variant, sampling


def crossing(seconds: np.ndarray, values: np.ndarray, target: float) -> tuple[float | None, bool]:
    """When a decreasing budget curve first falls below ``target``: ``(seconds, measured)``.

    Measured (``True``): interpolated linearly in log-seconds between the two checkpoints that bracket it.
    Otherwise a straight line through the points in log-seconds (least squares) is extrapolated (``False``),
    or ``(None, False)`` when the fitted curve does not fall. An extrapolation is a guess about a trend, not
    a measurement: say so wherever it is shown.
    """
    seconds, values = np.asarray(seconds, dtype=float), np.asarray(values, dtype=float)
    if len(seconds) != len(values) or len(seconds) < 2 or (seconds <= 0).any():
        raise ValueError("need at least two checkpoints with positive training seconds")
    log_t = np.log(seconds)
    below = np.flatnonzero(values < target)
    if below.size:
        k = int(below[0])
        if k == 0:
            return float(seconds[0]), True
        f = (values[k - 1] - target) / (values[k - 1] - values[k])
        return float(np.exp(log_t[k - 1] + f * (log_t[k] - log_t[k - 1]))), True
    slope, intercept = np.polyfit(log_t, values, 1)
    if slope >= 0:
        return None, False
    return float(np.exp((target - intercept) / slope)), False


def budget_curve(result: dict[str, Any], sampling: str, metric: str = "sjpe") -> tuple[np.ndarray, np.ndarray]:
    """``(training seconds, mean metric)`` at each checkpoint of a variant for one sampling."""
    seconds, values = [], []
    for point in result["checkpoints"]:
        runs = point["samplings"].get(sampling)
        if runs is not None:
            seconds.append(point["train_seconds"])
            values.append(np.mean([run[metric] for run in runs["runs"]]))
    return np.array(seconds), np.array(values)


def sweep_rows(
    sweep: dict[str, dict[str, Any]],
    samplings: Sequence[str] | None = None,
    metrics: Sequence[str] = ("sjpe", "noise_sjpe", "static_sjpe", "fid", "joint_jerk"),
) -> list[dict[str, Any]]:
    """One row per (variant, sampling) at the last checkpoint: steps, seconds, seed spread, metric estimates."""
    rows = []
    for variant, result in sweep.items():
        last = result["checkpoints"][-1]
        for sampling, scored in last["samplings"].items():
            if samplings is not None and sampling not in samplings:
                continue
            row = {
                "variant": variant,
                "sampling": sampling,
                "steps": last["step"],
                "train_seconds": last["train_seconds"],
                "seed_rms": scored.get("seed_rms", float("nan")),
            }
            row.update({m: estimate(result, sampling, m) for m in metrics})
            rows.append(row)
    return rows


__all__ = ["best_setting", "budget_curve", "crossing", "estimate", "load_sweep", "sweep_rows"]
