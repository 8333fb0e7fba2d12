"""Reading a DisCoRD decoder sweep: which parameterisation, sampling and budget give the smoothest decoder.

``experiments/discord_sweep.py`` trains each *variant* (a set of :class:`~motionlab.flow.DisCoRDConfig`
overrides) under one wall-clock budget and writes ``<variant>.json``: the feed-forward and ground-truth
scores on the validation clips, then, at fractions of the run (its *checkpoints*), the reconstruction scores of
the EMA weights under several *samplings* (start-noise temperature, time grid, last step), one run per
sampling seed. These helpers turn that folder into tables, curves and sentences; they compute nothing new.
A table row is one (variant, sampling) at the last checkpoint, named ``"variant, sampling"`` (:func:`row_name`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from motionlab.comparison import Sentence
from motionlab.estimate import Estimate

FEED_FORWARD = "feed-forward RVQ decoder"  # the reference rows of a sweep table
GROUND_TRUTH = "ground truth"
# What a sweep table can show, by key: its column header. The metrics are estimates over the sampling seeds.
SWEEP_COLUMNS = {
    "steps": "steps",
    "minutes": "minutes",
    "sjpe": "sJPE",
    "noise_sjpe": "Noise sJPE",
    "static_sjpe": "Static sJPE",
    "fid": "FID",
    "joint_jerk": "joint jerk (m/s³)",
    "seed_rms": "seed spread",
}
_FORMATS = {"minutes": ".0f", "joint_jerk": ".0f", "seed_rms": ".3f"}
_METRICS = ("sjpe", "noise_sjpe", "static_sjpe", "fid", "joint_jerk")
PAPER_PARAMETERS = "66.9 M"  # DisCoRD Table A's decoder


def load_sweep(folder: str | Path) -> dict[str, dict[str, Any]]:
    """Every ``<variant>.json`` of ``folder``, by variant name (sorted); raises if there is none."""
    folder = Path(folder)
    found = {p.stem: json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))}
    if not found:
        raise FileNotFoundError(f"no sweep results (*.json) in {folder}")
    return found


def longest_run(study: Mapping[str, dict[str, Any]], prediction: str | None = None) -> str:
    """The variant of ``study`` with the largest training budget, among those predicting ``prediction`` (``"v"`` or
    ``"x"``; None: every variant); the first in the study's order where budgets tie."""
    runs = [v for v, result in study.items() if prediction is None or result["config"]["prediction"] == prediction]
    if not runs:
        raise ValueError(f"no run of the sweep predicts {prediction!r}; its runs: {', '.join(study)}")
    return max(runs, key=lambda v: study[v]["budget_s"])


def estimate(result: dict[str, Any], sampling: str, metric: str, checkpoint: int = -1) -> Estimate:
    """Mean and 95% interval (Student's t) of ``metric`` over the sampling seeds of one checkpoint."""
    scored = result["checkpoints"][checkpoint]["samplings"]
    if sampling not in scored:  # a run scores the samplings its --samplings named
        raise KeyError(
            f"{result.get('variant', 'the run')} did not score sampling {sampling!r}; it scored {', '.join(scored)}"
        )
    return Estimate.from_values([run[metric] for run in scored[sampling]["runs"]])


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


def row_name(variant: str, sampling: str) -> str:
    """A sweep table's row: ``"x-w128, T0"``."""
    return f"{variant}, {sampling}"


def sweep_table(
    sweep: Mapping[str, Mapping[str, Any]],
    samplings: Sequence[str] | None = None,
    variants: Sequence[str] | None = None,
    columns: Sequence[str] = ("steps", "sjpe", "noise_sjpe", "static_sjpe", "fid", "joint_jerk", "seed_rms"),
    references: bool = True,
):
    """The last checkpoint of each (variant, sampling) as a :class:`~motionlab.viz.tables.Table`, one row each (only
    ``variants``/``samplings`` if given), ``columns`` among :data:`SWEEP_COLUMNS`; with ``references``, the
    feed-forward decoder's and the ground truth's scores on the same clips as the last rows. Its notes say what the
    intervals cover and how far the longest run is from the paper's training."""
    from motionlab.flow import discord_config
    from motionlab.viz.tables import Table

    unknown = [c for c in columns if c not in SWEEP_COLUMNS]
    if unknown:
        raise ValueError(f"unknown sweep columns {unknown}; the columns are {list(SWEEP_COLUMNS)}")
    chosen = [v for v in sweep if variants is None or v in variants]
    if not chosen:
        raise ValueError(f"none of the variants {list(variants or [])} is in the sweep ({list(sweep)})")
    rows, seeds = {}, set()
    for row in sweep_rows({v: sweep[v] for v in chosen}, samplings=samplings):
        cells = {"steps": int(row["steps"]), "minutes": row["train_seconds"] / 60, "seed_rms": row["seed_rms"]}
        cells.update({m: row[m] for m in _METRICS})
        cells["joint_jerk"] = row["joint_jerk"].mean  # for scale beside the references, not compared
        rows[row_name(row["variant"], row["sampling"])] = {SWEEP_COLUMNS[c]: cells[c] for c in columns}
        seeds.update({row["sjpe"].n} if row["sjpe"].half_width > 0 else set())
    if not rows:
        raise ValueError(f"no (variant, sampling) of the sweep is among the samplings {list(samplings or [])}")
    first = sweep[chosen[0]]
    if references:
        for name, scores, rms in (
            (FEED_FORWARD, first["feed_forward"], 0.0),
            (GROUND_TRUTH, first["ground_truth"], None),
        ):
            cells = {m: _finite(scores.get(m)) for m in _METRICS} | {"seed_rms": rms}
            rows[name] = {SWEEP_COLUMNS[c]: cells.get(c) for c in columns}
    paper = discord_config("full")
    windows = max(r["config"]["train_steps"] * r["config"]["batch_size"] for r in sweep.values())
    notes = (
        f"{first['clips']} validation clips of {first['dataset']}; ± is the 95% interval over "
        f"{'/'.join(str(n) for n in sorted(seeds)) or 'the'} sampling seeds (Student's t; none at temperature 0, "
        "where one decode is the whole distribution). Seed spread: the root-mean-square difference between two "
        "seeds' decodes of the same tokens (normalised features).",
        f"Batch {first['config']['batch_size']}; the paper's training ({paper.train_steps:,} steps at batch "
        f"{paper.batch_size}) saw {paper.train_steps * paper.batch_size / windows:,.0f}× more windows than the "
        "longest run here.",
    )
    formats = {SWEEP_COLUMNS[c]: f for c, f in _FORMATS.items() if c in columns}
    return Table("run, sampling", rows, columns=tuple(SWEEP_COLUMNS[c] for c in columns), notes=notes, formats=formats)


def _finite(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def sweep_findings(table, pairs: Sequence[tuple[str, str, str]], columns: Sequence[str] = ("sJPE",)):
    """One bullet per ``(row_a, row_b, what changed)`` whose two rows the table has: each of ``columns`` of ``row_a``
    against ``row_b`` by the one rule (:meth:`~motionlab.viz.tables.Table.compare`), as a
    :class:`~motionlab.comparison.Sentence` (Markdown); pairs with a row the sweep did not run are left out."""
    lines = []
    for a, b, what in pairs:
        if a in table.rows and b in table.rows:
            said = "; ".join(str(table.compare(a, b, column)) for column in columns)
            lines.append(f"- {what}: {said}.")
    return Sentence("\n".join(lines))


def sampling_of(config: Any) -> str:
    """The sweep's name of how a :class:`~motionlab.flow.DisCoRDConfig` samples: ``"T0"``, ``"T1-dense"``, ..."""
    dense = "-dense" if config.spacing == "data_dense" else ""
    return f"T{config.temperature:g}{dense}{'-final' if config.final_prediction else ''}"


def matches_setting(config: Any, result: Mapping[str, Any], sampling: str) -> bool:
    """Whether ``config`` is the sweep variant ``result`` (every override it trained with) sampled as ``sampling``."""
    same = all(getattr(config, name) == value for name, value in result["overrides"].items())
    return same and sampling_of(config) == sampling


def crossing_sentence(result: Mapping[str, Any], sampling: str, target: float, metric: str = "sjpe"):
    """When a run's budget curve of ``metric`` falls below ``target`` (the feed-forward decoder's), as a
    :class:`~motionlab.comparison.Sentence` that says whether that was measured between two checkpoints, extrapolated
    along a straight line in log-time (a guess, not a measurement), or not in sight (:func:`crossing`)."""
    name = SWEEP_COLUMNS.get(metric, metric)
    seconds, values = budget_curve(result, sampling, metric)
    when, measured = crossing(seconds, values, target)
    span = f"{seconds[0] / 60:.0f}–{seconds[-1] / 60:.0f} training minutes of `{result['variant']}` at {sampling}"
    if when is None:
        return Sentence(f"{name} does not fall over {span}: no crossing in sight.")
    if measured:
        return Sentence(
            f"{name} falls below the feed-forward decoder's ({target:.3f}) after about **{when / 60:.0f} minutes** "
            f"of training (measured, between two checkpoints of {span})."
        )
    return Sentence(
        f"{name} stays above the feed-forward decoder's ({target:.3f}) over {span}; a straight line in log-time "
        f"reaches it after about **{when / 60:.0f} minutes**: an extrapolation, not a measurement."
    )


def settings_table(config: Any, paper: Any = None):
    """A DisCoRD decoder's settings beside the paper's (Table A; default ``discord_config("full")``), as a
    :class:`~motionlab.viz.tables.Table`: what a sweep varies and what the chapter's run uses."""
    from motionlab.flow import DisCoRDDecoder, discord_config, n_evaluations
    from motionlab.viz.tables import Table

    paper = discord_config("full") if paper is None else paper

    def settings(c: Any, parameters: str) -> dict[str, str]:
        nfe = n_evaluations(c.sample_steps, c.solver)
        return {
            "U-Net width, levels": f"{c.width}, {len(c.width_mults) + 1}",
            "condition d → c": f"{c.code_dim} → {c.cond_dim}",
            "parameters": parameters,
            "window × batch": f"{c.window} × {c.batch_size}",
            "steps (warm-up)": f"{c.train_steps:,} ({c.warmup_steps:,})",
            "lr, EMA decay": f"{c.lr:g} → {c.min_lr:g}, {c.ema_decay}",
            "network predicts, normalisation": f"{c.prediction}, {c.normalization}",
            "training times, start-noise temperature": f"{c.time_distribution}, {c.temperature:g}",
            "decode default": f"{c.sample_steps} {c.solver} steps ({nfe} evaluations)",
        }

    count = sum(p.numel() for p in DisCoRDDecoder(config).parameters())
    mine, theirs = settings(config, f"{count / 1e6:.2f} M"), settings(paper, PAPER_PARAMETERS)
    rows = {name: {"this run": mine[name], "DisCoRD (Table A)": theirs[name]} for name in mine}
    return Table("", rows)


__all__ = [
    "FEED_FORWARD",
    "GROUND_TRUTH",
    "SWEEP_COLUMNS",
    "best_setting",
    "budget_curve",
    "crossing",
    "crossing_sentence",
    "estimate",
    "load_sweep",
    "longest_run",
    "matches_setting",
    "row_name",
    "sampling_of",
    "settings_table",
    "sweep_findings",
    "sweep_rows",
    "sweep_table",
]
