"""The scale study run point by point: train a point's models at a multiple of the laptop budget, score them with the
chapters' evaluations, and predict what a point costs on a GPU from the GPU benchmark's measured step times.

What a point is, and how a multiple changes a model's training, is :mod:`motionlab.evaluation.scale`'s (the book
reads the records through :mod:`motionlab.report.scale`); ``experiments/scale.py`` runs the points and writes them.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from motionlab.estimate import Estimate
from motionlab.evaluation.scale import (
    GROUPS,
    PROJECTIONS,
    group_evaluations,
    group_models,
    point_configs,
    scaled_budgets,
    training_steps,
)
from motionlab.models import benchmark_model, compiled_part

from .carry import config_key

TIMED_VARIANT = "library train_step"  # what the study runs: the library's trainer, not the bare module


def _log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------------------------------- the plan
@dataclass(frozen=True)
class PlannedModel:
    """One model of a point: its steps and batch at the multiple, and its predicted GPU seconds (None: no rate)."""

    name: str
    steps: int
    batch: int
    seconds: float | None  # for the steps left
    why: str  # where the prediction comes from, or why there is none
    done: int = 0  # steps the cache has trained already (a checkpoint in progress; all of them: finished)


@dataclass(frozen=True)
class Point:
    """One group at one multiple, with the batch factor it trains at."""

    group: str
    multiple: float
    batch_factor: int = 1

    @property
    def key(self) -> str:
        """The record's file stem: ``discord-x10``."""
        return f"{self.group}-x{self.multiple:g}"


def auto_batch_factor(multiple: float, group: str, profile: str, device: str, run=None) -> int:
    """The batch factor of a point: 1 on a CPU (the laptop's batch); on a GPU the largest power of two that keeps
    every model's batch within the batch the GPU benchmark timed it at (so that the benchmark's step time bounds this
    point's step from above) and the steps at least the profile's (``b ≤ multiple``)."""
    if not device.startswith("cuda") or run is None:
        return 1
    profile_batches = {name: training_steps(c)[1] for name, c in _configs(Point(group, 1), profile).items()}
    limit = max(1, int(multiple))
    for name, batch in profile_batches.items():
        timed = _timed_batch(run, benchmark_model(name))
        if timed is not None:
            limit = min(limit, max(1, timed // batch))
    factor = 1
    while factor * 2 <= limit:
        factor *= 2
    return factor


def _timed_batch(run, kind: str | None) -> int | None:
    batches = [r["batch"] for r in run.train if r["model"] == kind and r["variant"] == TIMED_VARIANT]
    return min(batches) if batches else None


def _configs(point: Point, profile: str) -> dict[str, Any]:
    """The training configs (JSON dicts) of the models ``point`` trains, at its multiple."""
    models = point_configs(point.group, point.multiple, point.batch_factor, profile)["models"]
    return {name: models[name] for name in group_models(point.group)}


@dataclass(frozen=True)
class Rates:
    """What a plan predicts from: the GPU benchmark's run (``run``, a :class:`~motionlab.report.gpu.GPURun`, or None),
    and the points already recorded on this kind of device in this precision (:func:`measured_rates`), which beat the
    benchmark where they measured the same model at the same batch."""

    precision: str = "bf16"
    run: Any = None
    steps: dict[tuple[str, int], tuple[float, str]] = field(default_factory=dict)  # (model, batch) -> (ms, point)
    scoring: dict[str, tuple[float, str]] = field(default_factory=dict)  # group -> (seconds, point)

    def step_ms(self, name: str, batch: int) -> tuple[float | None, str]:
        """One training step of ``name`` at ``batch`` in milliseconds, and where that number comes from."""
        if (name, batch) in self.steps:
            ms, point = self.steps[name, batch]
            return ms, f"{ms:.3g} ms measured in {point}"
        kind = benchmark_model(name)
        ms = self.run.step_ms(kind, TIMED_VARIANT, self.precision) if self.run is not None and kind else None
        if ms is None:
            if self.run is None:
                return None, "no GPU benchmark"
            return None, f"no {self.precision} rate for it in {self.run.path.name}"
        before = ", recorded before the library's step got faster" if self.run.predates() else ""
        return ms, f"{ms:g} ms ({kind}, {self.precision}, {self.run.path.name}{before}: an upper bound)"

    def compile_seconds(self, name: str, batch: int) -> tuple[float, str]:
        """Seconds ``name`` compiles for before it trains on the GPU, and a phrase saying so (``""``: nothing to add).

        Only where the step time is the benchmark's: a point recorded here timed its compiling inside its seconds.
        Each model compiles when its training starts, so each pays it; the benchmark's compile of the full-size
        network stands in for it (the inductor cache under ``$MOTIONLAB_HOME`` can make a later one shorter).
        """
        from motionlab.train.compiling import GRAPHED, compile_mode

        part = compiled_part(name)
        mode = compile_mode(part, "cuda") if part is not None else None
        if self.run is None or (name, batch) in self.steps or mode is None:
            return 0.0, ""
        bench = benchmark_model(name)
        seconds = None if bench is None else self.run.compile_seconds(bench, self.precision, mode == GRAPHED)
        if seconds is None:
            return 0.0, f"; it compiles first, for a time {self.run.path.name} did not measure"
        return seconds, f"; {seconds:.0f} s of it compiling"


def measured_rates(records: list[dict], device_type: str, precision: str, run=None) -> Rates:
    """:class:`Rates` with the step times and scoring times that ``records`` (points written by
    ``experiments/scale.py``) measured on ``device_type`` in ``precision``: a model's seconds over its steps (from
    its sittings on ``device_type``), and a group's scoring seconds (its evaluation does not depend on the
    multiple)."""
    steps, scoring = {}, {}
    for record in sorted(records, key=lambda r: r["multiple"]):  # the largest multiple last: it wins
        if record.get("device_type") != device_type or record.get("precision") != precision:
            continue
        point = f"{record['group']}-x{record['multiple']:g}"
        for name, model in record["models"].items():
            if (ms := _step_ms(model, device_type)) is not None:
                steps[name, model["batch"]] = (ms, point)
        scoring[record["group"]] = (record["seconds"]["scoring"], point)
    return Rates(precision, run, steps, scoring)


def _step_ms(model: dict, device_type: str) -> float | None:
    """A recorded model's milliseconds per training step over its sittings on ``device_type`` (None: none timed)."""
    timed = [s for s in model["sittings"] if s.get("device") == device_type and s.get("seconds") is not None]
    n = sum(s["steps"][1] - s["steps"][0] for s in timed)
    return 1e3 * sum(s["seconds"] for s in timed) / n if n > 0 else None


def plan_point(
    point: Point, profile: str, rates: Rates, progress: Mapping[str, float] | None = None
) -> list[PlannedModel]:
    """Each model of ``point`` with its steps, batch and predicted training seconds: the steps not yet trained (by
    ``progress``, :func:`motionlab.studies.carry.cached_progress`) × the step time measured in an earlier point here,
    else the library's step the GPU benchmark timed for its kind at the papers' widths and a batch at least this
    one's (an upper bound for the laptop's narrower networks), plus its compile time where the run compiles it
    (:meth:`Rates.compile_seconds`). None where neither measured it."""
    planned = []
    for name, config in _configs(point, profile).items():
        steps, batch = training_steps(config)
        done = int(min(steps, (progress or {}).get(config_key(config), 0)))
        ms, source = rates.step_ms(name, batch)
        seconds = None if ms is None else (steps - done) * ms / 1e3
        if seconds is not None and done < steps:
            compiling, said = rates.compile_seconds(name, batch)
            seconds, source = seconds + compiling, source + said
        planned.append(PlannedModel(name, steps, batch, seconds, source, done))
    return planned


def predicted_seconds(planned: list[PlannedModel], scoring: float | None = 0.0) -> float | None:
    """A point's predicted seconds (its training left, plus ``scoring`` where known), or None where a model with
    steps left has no measured rate."""
    seconds = [0.0 if m.done == m.steps else m.seconds for m in planned]
    return None if any(s is None for s in seconds) else sum(seconds) + (scoring or 0.0)


def point_seconds(
    point: Point, profile: str, rates: Rates, progress: Mapping[str, float] | None = None
) -> float | None:
    """A point's predicted seconds, training left (by ``progress``) and (where an earlier point measured it)
    scoring."""
    scoring = rates.scoring.get(point.group, (None, ""))[0]
    return predicted_seconds(plan_point(point, profile, rates, progress), scoring)


def plan_lines(
    points: list[Point],
    profile: str,
    rates: Rates,
    done=(),
    minutes: float | None = None,
    progress: Mapping[str, float] | None = None,
) -> list[str]:
    """The plan as lines for a reader: each point, its models' steps × batch and predicted time, and the total; a
    point predicted to outlast ``minutes`` (one run) is flagged. ``progress`` (:func:`~.carry.cached_progress`) is
    what the cache has trained already; a model an earlier pending point trains costs a later one nothing."""
    run = rates.run
    if run is not None:
        source = f"else the library's train_step in the GPU benchmark {run.path.name} ({run.machine['device']})"
    else:
        source = "no GPU benchmark (it predicts GPU runs only)"
    lines = [f"scale study plan, profile {profile}, {rates.precision}; step times from the points recorded here,"]
    lines.append(f"  {source}:")
    progress = dict(progress or {})
    trained_by: dict[str, str] = {}  # config -> the pending point that trains it first
    total, unknown = 0.0, 0
    for point in points:
        pending = point.key not in done
        planned = plan_point(point, profile, rates, progress if pending else {})
        scoring, scored_in = rates.scoring.get(point.group, (None, ""))
        seconds = predicted_seconds(planned, scoring)
        status = "recorded" if not pending else (f"~{seconds / 60:.1f} min" if seconds is not None else "?")
        if pending and minutes is not None and seconds is not None and seconds > 60 * minutes:
            status += f" (more than --minutes {minutes:g}: it may not finish in one run)"
        lines.append(f"  {point.key} (batch ×{point.batch_factor}): {status}")
        configs = _configs(point, profile)
        for m in planned:
            key = config_key(configs[m.name])
            lines.append(f"    {m.name}: {m.steps:,} steps × batch {m.batch}: {_model_plan(m, trained_by.get(key))}")
            if pending and key not in trained_by and m.done < m.steps:
                trained_by[key], progress[key] = point.key, float("inf")
        scored = f"{scoring / 60:.2f} min (measured in {scored_in})" if scoring is not None else "not predicted"
        lines.append(f"    scoring: {scored}")
        if pending:
            total += seconds or 0.0
            unknown += seconds is None
    tail = f"; {unknown} point(s) with a model nothing has timed" if unknown else ""
    lines.append(f"  to do: ~{total / 60:.1f} min predicted{tail}")
    return lines


def _model_plan(m: PlannedModel, trained_by: str | None) -> str:
    """One model's line of the plan after its steps × batch."""
    if m.done == m.steps:
        return f"trained by {trained_by} first" if trained_by else "in the cache"
    time_text = f"{m.seconds / 60:.2f} min" if m.seconds is not None else "not predicted"
    if m.done:
        time_text += f" for the {m.steps - m.done:,} steps after the checkpoint at {m.done:,}"
    return f"{time_text} ({m.why})"


# ------------------------------------------------------------------------------------------- train and score
def train_point(point: Point, dataset, profile: str, device: str | None) -> dict[str, dict[str, Any]]:
    """Train (or load from the cache) each model of ``point`` inside its scaled budget: ``{name: {"sittings": [...]}}``,
    every process that trained the model, this one and earlier ones (:func:`motionlab.train.training_sittings`: steps,
    seconds, device), so a model trained run by run keeps its whole time and one loaded from the cache keeps the time
    it took where it was trained. Which models this run trained it logs ("training" or "loading")."""
    from motionlab import models
    from motionlab.paths import cache_dir
    from motionlab.precision import resolve_precision
    from motionlab.train import get_device, training_sittings

    from .carry import find_artefact

    out = {}
    configs = _configs(point, profile)
    precision = resolve_precision(None, get_device(device))  # what these models train in: part of their cache key
    with scaled_budgets(point.multiple, point.batch_factor, profile):
        for name in group_models(point.group):
            _log(f"{point.key}: {'loading' if _cached(name, dataset, profile, device) else 'training'} {name}")
            start = time.perf_counter()
            models.load(name, dataset, profile, device=device)
            folder = find_artefact(cache_dir(), configs[name], precision)
            out[name] = {"sittings": training_sittings(folder) if folder is not None else []}
            _log(f"{point.key}: {name} ready in {time.perf_counter() - start:.1f} s")
    return out


def _cached(name: str, dataset, profile: str, device: str | None) -> bool:
    """Whether ``name`` would only be loaded (the cache's own probe, so it cannot disagree with the load)."""
    from motionlab import models
    from motionlab.train.cache import NotCached, cache_probe

    with cache_probe():
        try:
            models.load(name, dataset, profile, device=device)
        except NotCached:
            return False
    return True


def score_point(point: Point, dataset, profile: str, device: str | None) -> tuple[dict[str, Estimate], dict]:
    """The claim numbers of ``point`` (``{"discord/sjpe_rf": Estimate, ...}``) and its tables as JSON dicts, from the
    chapters' evaluations of the models trained at its multiple."""
    evaluations = group_evaluations(point.group, profile)
    with scaled_budgets(point.multiple, point.batch_factor, profile):
        _log(f"{point.key}: scoring with {', '.join(evaluations)}")
        return SCORERS[point.group](evaluations, dataset, profile, device)


def _discord(evaluations: dict, dataset, profile: str, device) -> tuple[dict[str, Estimate], dict]:
    """Chapter 05's claim cells, and the paired differences over the test clips it records beside them."""
    from motionlab.evaluation import evaluate_reconstruction, reconstruction_clip_cells
    from motionlab.evaluation.studies import reconstruction_values

    config = evaluations["reconstruction"]
    table = evaluate_reconstruction(dataset, config, profile, device=device)
    values = reconstruction_values(table, config)
    for key, (a, b, metric) in reconstruction_clip_cells(table, config).items():
        values[f"discord/{key}"] = table.paired_clips(a, b, metric)
    return values, {"reconstruction": table.to_json_dict()}


def _projection(evaluations: dict, dataset, profile: str, device) -> tuple[dict[str, Estimate], dict]:
    """Chapter 04's ablation table of the three projection decoders on the point's RVQ tokens."""
    from motionlab import models
    from motionlab.studies.ablation import projection_ablation, projection_claim_cells

    sizes = evaluations["projection"]
    tokenizer = models.load("tokenizer/rvq", dataset, profile, device=device)
    decoders = {p: models.load(f"discord/rvq-{p}", dataset, profile, device=device) for p in PROJECTIONS}
    table = projection_ablation(
        decoders, tokenizer, dataset, windows=sizes["windows"], clips=sizes["clips"], seed=sizes["seed"]
    )
    values = {f"projection/{k}": table.estimate(row, m) for k, (row, m) in projection_claim_cells(PROJECTIONS).items()}
    return values, {"projection": table.to_json_dict()}


def _m2d2m(evaluations: dict, dataset, profile: str, device) -> tuple[dict[str, Estimate], dict]:
    """Chapter 09's multi-motion cells (the multi-motion model; TPS of the uniform one), chapter 07's guidance rows
    and chapter 08's dynamic-vs-uniform FID, as the training-seed study reads them."""
    from motionlab.evaluation import evaluate_multi, evaluate_t2m
    from motionlab.evaluation.studies import m2d2m_values, transitions_values

    paper, arms, guidance, single = (evaluations[r] for r in ("multi", "multi_uniform", "guidance", "t2m"))
    table, uniform_table = (evaluate_multi(dataset, c, profile, device=device) for c in (paper, arms))
    t2m, transitions = (evaluate_t2m(dataset, c, profile, device=device) for c in (guidance, single))
    values = m2d2m_values(table, uniform_table, t2m, guidance) | transitions_values(transitions, single)
    tables = {"multi": table, "multi_uniform": uniform_table, "guidance": t2m, "t2m": transitions}
    return values, {role: t.to_json_dict() for role, t in tables.items()}


SCORERS: dict[str, Callable] = {"discord": _discord, "projection": _projection, "m2d2m": _m2d2m}
assert set(SCORERS) == set(GROUPS)


def estimate_json(estimate: Estimate) -> dict[str, Any]:
    """An estimate as the record stores it (the report reads it back with :func:`motionlab.report.scale`)."""
    return {"mean": estimate.mean, "half_width": estimate.half_width, "n": estimate.n, "unit": estimate.unit}


__all__ = [
    "PlannedModel",
    "Point",
    "Rates",
    "measured_rates",
    "point_seconds",
    "auto_batch_factor",
    "plan_lines",
    "plan_point",
    "predicted_seconds",
    "score_point",
    "train_point",
]
