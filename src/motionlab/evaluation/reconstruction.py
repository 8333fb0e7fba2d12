"""DisCoRD Table 1: test clips → tokens → decoded by the feed-forward decoder and by DisCoRD, scored."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from motionlab.estimate import Estimate, mean_ci
from motionlab.profiles import get_profile
from motionlab.report.claims import PAPER_NUMBERS

from .common import (
    FLOW_OPTIONS,
    FLOW_SAMPLING_OPTIONS,
    FLOW_TRAINING_OPTIONS,
    _bar,
    _check_common,
    _check_flow_options,
    _check_int,
    _config,
    _flow_label,
    _flow_options_label,
    _phase,
    _split_clips,
    _table,
    command_line,
    repeat_seed,
)
from .table import RECONSTRUCTION_METRICS, EvaluationTable

GROUND_TRUTH = "Ground truth"  # the row of the real motion's own joint jerk (with ``jerk``)
TIMING_BATCH = 32  # Table E times one batch of 32 token sequences


def _paper_row(decoder: str) -> dict[str, Estimate]:
    # the paper prints sJPE on the ratio variant's [0, 1] scale: its numbers go in that column
    keys = {"fid": "fid", "mpjpe_mm": "mpjpe", "sjpe_ratio": "sjpe"}
    return {metric: Estimate(PAPER_NUMBERS[f"discord/{key}_{decoder}"][0]) for metric, key in keys.items()}


# DisCoRD Table 1 as printed (HumanML3D, MoMask's tokens): rows to set beside an evaluation's (``table.with_rows``).
PAPER_TABLE_1 = {"paper, HumanML3D: MoMask": _paper_row("ff"), "paper, HumanML3D: MoMask + DisCoRD": _paper_row("rf")}


@dataclass(frozen=True)
class ReconstructionConfig:
    """DisCoRD Table 1. ``decoder``: ``"vq"``/``"rvq"`` (that tokenizer's feed-forward decoder alone) or
    ``"discord"`` (the feed-forward row and the DisCoRD row, both on ``tokenizer``'s ids; default ``"rvq"``
    as MoMask + DisCoRD, ``"vq"`` gives T2M-GPT + DisCoRD). ``repeats`` applies to the DisCoRD row only.
    ``prediction``/``normalization``/``time_distribution`` choose (and train on first use) a decoder other than
    the profile's; ``temperature``/``spacing``/``final_prediction`` change only how it samples.

    Beyond Table 1 (each adds columns or rows, and the CLI prints them):

    - ``grid``: DisCoRD Table E, one more DisCoRD row per ``(solver, intervals)`` (a ``"euler:1,midpoint:15"`` text
      is read too), each decoded from the first ``grid_repeats`` seeds of the DisCoRD row (default ``repeats``);
    - ``timing_repeats``: a time column (mean over that many timed decodes of one batch of the 32 longest clips,
      after one untimed) and the GFLOPs of one such decode, for every decoder row;
    - ``jerk``: the mean joint jerk (m/s³) of the sJPE joints as a column, and a ground-truth row with the real
      motion's own;
    - ``token_phases``: Noise sJPE split by where each jerk stencil sits in the token grid, one column per phase
      (phase 0 centred on a token boundary; they sum to Noise sJPE), and phase 0's share of the total.
    """

    decoder: str = "discord"
    tokenizer: str | None = None
    steps: int | None = None  # ODE intervals (None: the decoder's config)
    solver: str | None = None  # "euler" | "midpoint" (None: the decoder's config)
    prediction: str | None = None  # "v" | "x"
    normalization: str | None = None  # "std" | "feat_bias"
    time_distribution: str | None = None  # "uniform" | "logit_normal"
    temperature: float | None = None  # start-noise scale
    spacing: str | None = None  # "uniform" | "data_dense"
    final_prediction: bool | None = None  # x-prediction: return x̂1 at the last step
    split: str = "test"
    limit: int | None = None  # the first `limit` clips of the split
    repeats: int = 1
    seed: int = 0
    grid: tuple[tuple[str, int], ...] = ()  # Table E rows: (solver, intervals), e.g. ("midpoint", 15)
    grid_repeats: int | None = None  # sampling seeds of each grid row (None: repeats)
    timing_repeats: int = 0  # timed decodes per decoder row (0: no time column)
    jerk: bool = False
    token_phases: bool = False

    def __post_init__(self):
        object.__setattr__(self, "grid", _parse_grid(self.grid))
        if self.decoder not in ("vq", "rvq", "discord"):
            raise ValueError(f"decoder must be 'vq', 'rvq' or 'discord', got {self.decoder!r}")
        if self.tokenizer is not None and self.tokenizer not in ("vq", "rvq"):
            raise ValueError(f"tokenizer must be 'vq' or 'rvq', got {self.tokenizer!r}")
        if self.tokenizer is not None and self.decoder != "discord":
            raise ValueError(
                f"decoder={self.decoder!r} is that tokenizer's own decoder; tokenizer= chooses the "
                "tokens of decoder='discord' only"
            )
        _check_flow_options(self, self.decoder == "discord")
        _check_common(self, 2, " (FID needs two clips)")
        if self.grid and self.decoder != "discord":
            raise ValueError("grid adds DisCoRD rows; it needs decoder='discord'")
        if self.grid_repeats is not None:
            _check_int("grid_repeats", self.grid_repeats, 1)
            if not self.grid:
                raise ValueError("grid_repeats sets the seeds of the grid rows; it needs a grid")
        _check_int("timing_repeats", self.timing_repeats, 0)
        for name in ("jerk", "token_phases"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be True or False, got {getattr(self, name)!r}")

    @classmethod
    def from_sizes(cls, sizes: Any, **options: Any) -> ReconstructionConfig:
        """Chapter 05's evaluation from its sizes (``settings.sizes.discord``, :mod:`motionlab.sizes`): Table 1 on
        ``test_clips`` clips with ``seeds`` sampling seeds, Table E's Euler and midpoint rows with ``grid_seeds``
        seeds, timed ``timing_repeats`` times, with the joint jerk and Noise sJPE by token phase; ``options``
        override fields (e.g. ``seed``)."""
        from motionlab.sizes import DiscordSizes

        if not isinstance(sizes, DiscordSizes):
            raise ValueError(f"sizes must be DiscordSizes (settings.sizes.discord), got {type(sizes).__name__}")
        unknown = sorted(set(options) - {f.name for f in fields(cls)})
        if unknown:
            raise ValueError(f"unknown ReconstructionConfig option(s): {', '.join(unknown)}")
        grid = [("euler", s) for s in sizes.euler_steps] + [("midpoint", s) for s in sizes.midpoint_steps]
        chosen = dict(
            limit=sizes.test_clips,
            repeats=sizes.seeds,
            grid=tuple(grid),
            grid_repeats=sizes.grid_seeds if grid else None,
            timing_repeats=sizes.timing_repeats,
            jerk=True,
            token_phases=True,
        )
        return cls(**{**chosen, **options})

    def grid_row(self, solver: str, steps: int) -> str:
        """The row name of the grid's ``(solver, steps)`` decode: ``"DisCoRD, 15 midpoint steps (30 evaluations)"``."""
        from motionlab.flow import n_evaluations

        if (solver, steps) not in self.grid:
            raise KeyError(f"({solver!r}, {steps}) is not in this config's grid {list(self.grid)}")
        nfe = n_evaluations(steps, solver)
        return f"DisCoRD, {steps} {solver} step{'s' * (steps != 1)} ({nfe} evaluation{'s' * (nfe != 1)})"

    def command_line(self, profile: str | None = None) -> str:
        """The ``motionlab evaluate reconstruction`` command that computes this table (see :func:`command_line`)."""
        return command_line(self, "reconstruction", profile)

    @property
    def tokenizer_kind(self) -> str:
        return self.decoder if self.decoder != "discord" else (self.tokenizer or "rvq")


def _parse_grid(grid: Any) -> tuple[tuple[str, int], ...]:
    """``"euler:1,midpoint:15"``, ``["euler:1"]`` or ``[("euler", 1)]`` -> ``(("euler", 1), ...)``, checked."""
    from motionlab.flow import SOLVERS

    if grid is None:
        return ()
    items = [part.strip() for part in grid.split(",") if part.strip()] if isinstance(grid, str) else list(grid)
    out = []
    for item in items:
        if isinstance(item, str):
            solver, _, steps = item.partition(":")
            try:
                item = (solver.strip(), int(steps))
            except ValueError as err:
                raise ValueError(f"grid entries look like 'midpoint:15', got {item!r}") from err
        if not isinstance(item, (tuple, list)) or len(item) != 2:
            raise ValueError(f"grid entries are (solver, steps) pairs or 'solver:steps' texts, got {item!r}")
        solver, steps = item
        if solver not in SOLVERS:
            raise ValueError(f"grid solver must be one of {SOLVERS}, got {solver!r}")
        _check_int("grid steps", steps, 1)
        out.append((str(solver), int(steps)))
    if len(set(out)) != len(out):
        raise ValueError(f"grid entries must be distinct, got {out}")
    return tuple(out)


# ----------------------------------------------------------------------------------------------- the tasks


def evaluate_reconstruction(
    dataset,
    config: ReconstructionConfig | None = None,
    profile: str | None = None,
    *,
    device: str | None = None,
    progress: bool = False,
) -> EvaluationTable:
    """DisCoRD Table 1 on ``config.split``: ground truth → tokens → decoded, scored against the ground truth.

    The ground truth is each clip cropped to whole tokens (raw features); FID compares evaluator embeddings
    of the reconstructions with those of the ground truth. The feed-forward row is one run (deterministic);
    the DisCoRD row repeats ``config.repeats`` times, repeat r decoding from seed ``repeat_seed(seed, r)``, except
    at sampling temperature 0, where every seed decodes the same motion and one run is the whole distribution.
    The rows are, in order: the feed-forward decoder, DisCoRD, then (with the options of :class:`ReconstructionConfig`)
    the grid rows and the ground truth. :attr:`EvaluationTable.samples` holds every row's values run by run.
    """
    from motionlab.flow.reconstruction import decode_clips, reconstruction_scores
    from motionlab.metrics import ClipJoints
    from motionlab.metrics.evaluator_training import load_or_train_evaluator
    from motionlab.tokenizers import tokenizer_for_dataset

    cfg = _config(config, ReconstructionConfig)
    profile = get_profile(profile)
    clips = _split_clips(dataset, cfg.split, cfg.limit, 2, "FID")
    kind = cfg.tokenizer_kind
    _phase(
        f"reconstruction: {len(clips)} {cfg.split} clips; loading (or training) the {kind} tokenizer and the evaluator"
    )
    tokenizer = tokenizer_for_dataset(kind, dataset, profile, device=device, progress=progress)
    evaluator = load_or_train_evaluator(dataset, profile, device=device, progress=progress)
    q, normalizer = int(tokenizer.downsample), dataset.normalizer
    normalized = [normalizer.normalize(c.features) for c in clips]  # (T_i, D) each, what the tokenizer reads
    gt = [c.features[: len(c.features) // q * q] for c in clips]  # raw, whole tokens
    gt_embeddings = evaluator.embed_motions(gt)  # (N, d), shared by every row's FID
    gt_joints = ClipJoints.from_features(gt)  # recovered once, shared by every row's MPJPE and sJPE
    phases = _phase_metrics(q) if cfg.token_phases else ()

    def score(recon: list[np.ndarray]) -> dict[str, float]:
        raw = [normalizer.denormalize(r) for r in recon]
        joints = ClipJoints.from_features(raw)
        scores = reconstruction_scores(raw, gt, evaluator.embed_motions, gt_embeddings, gt_joints, joints).as_dict()
        if phases:
            scores.update(_token_phases(joints, gt_joints, q))
        return scores

    name = "VQ-VAE" if kind == "vq" else "RVQ-VAE"
    feed_forward = f"{name} decoder"
    _phase(f"scoring the {feed_forward}")
    runs = {feed_forward: [score(decode_clips(normalized, tokenizer))]}
    deterministic = [feed_forward]
    notes = ["The feed-forward decoder is deterministic: one run, no interval."]
    timers: dict[str, Callable[[], Any]] = {}
    batch = _timing_batch(normalized, tokenizer) if cfg.timing_repeats else None
    if batch is not None:
        timers[feed_forward] = lambda: tokenizer.decode(batch)
    if cfg.decoder == "discord":
        from motionlab.flow import discord_config, train_or_load_discord

        chosen = {name: getattr(cfg, name) for name in FLOW_OPTIONS if getattr(cfg, name) is not None}
        training = {k: v for k, v in chosen.items() if k in FLOW_TRAINING_OPTIONS}
        flow_config = discord_config(profile, tokenizer=tokenizer, **training)
        _phase("loading (or training) the DisCoRD decoder")
        flow = train_or_load_discord(dataset, tokenizer, profile, config=flow_config, device=device, progress=progress)
        sampling = {k: v for k, v in chosen.items() if k in FLOW_SAMPLING_OPTIONS}
        flow = flow.with_sampling(**sampling) if sampling else flow
        seeded = not flow.deterministic  # at temperature 0 every seed decodes the same motion
        decoded: dict[tuple[int, str], list[dict[str, float]]] = {}  # (steps, solver) -> runs, repeat by repeat

        def flow_runs(steps: int, solver: str, repeats: int, what: str) -> list[dict[str, float]]:
            # repeat r always decodes from repeat_seed(seed, r): a grid row at the DisCoRD row's steps reuses its runs
            done = decoded.setdefault((steps, solver), [])
            todo = range(len(done), repeats if seeded else 1)
            with _bar(len(todo), f"DisCoRD {what}", progress) as bar:
                for r in todo:
                    _phase(f"DisCoRD {what}: repeat {r + 1} of {repeats if seeded else 1}")
                    seed = repeat_seed(cfg.seed, r)
                    recon = decode_clips(normalized, tokenizer, flow, steps=steps, solver=solver, seed=seed)
                    done.append(score(recon))
                    bar.update()
            return done[: repeats if seeded else 1]

        def timer(steps: int, solver: str) -> Callable[[], Any]:
            seed = repeat_seed(cfg.seed, 0)
            return lambda: flow.decode(batch, tokenizer=tokenizer, steps=steps, solver=solver, seed=seed)

        steps = flow.config.sample_steps if cfg.steps is None else cfg.steps
        solver = flow.config.solver if cfg.solver is None else cfg.solver
        flow_row = f"{name} tokens + DisCoRD ({_flow_label(flow, cfg.steps, cfg.solver)}{_flow_options_label(flow)})"
        runs[flow_row] = flow_runs(steps, solver, cfg.repeats, "repeats")
        if batch is not None:
            timers[flow_row] = timer(steps, solver)
        flow_rows = [flow_row]
        grid_repeats = cfg.repeats if cfg.grid_repeats is None else cfg.grid_repeats
        for grid_solver, grid_steps in cfg.grid:
            row = cfg.grid_row(grid_solver, grid_steps)
            runs[row] = flow_runs(grid_steps, grid_solver, grid_repeats, f"{grid_steps} {grid_solver} steps")
            if batch is not None:
                timers[row] = timer(grid_steps, grid_solver)
            flow_rows.append(row)
        if seeded:
            notes.append(f"DisCoRD: {cfg.repeats} sampling seeds.")
        else:
            notes.append("DisCoRD at temperature 0 decodes every seed to the same motion: one run, no interval.")
            deterministic.extend(flow_rows)
        if cfg.grid:
            seeds = f"the first {grid_repeats} of the DisCoRD row's seeds" if seeded else "one run each"
            notes.append(
                f"Grid rows: the same decoder{_flow_options_label(flow)} with other ODE steps, {seeds}; "
                "an evaluation is one network call."
            )
    rows = {row: _summarize(values) for row, values in runs.items()}
    samples = {row: {m: [run[m] for run in values] for m in values[0]} for row, values in runs.items()}
    metrics = list(RECONSTRUCTION_METRICS)
    if cfg.jerk:
        metrics.append("joint_jerk")
        own = reconstruction_scores(gt, gt, gt_joints=gt_joints, pred_joints=gt_joints).joint_jerk
        rows[GROUND_TRUTH] = {"joint_jerk": Estimate(own)}
        deterministic.append(GROUND_TRUTH)
        notes.append("Joint jerk: the mean jerk magnitude of the sJPE joints; the ground truth's is its own.")
    if phases:
        metrics.extend(phases + ("noise_sjpe_boundary_share",))
        notes.append(
            f"Noise sJPE by token phase: the part from jerk stencils at phase p of the {q}-frame token grid (phase 0 "
            f"centred on a token boundary; the phases sum to Noise sJPE); a decoder blind to the grid has a share of "
            f"{1 / q:.2f} on the boundaries."
        )
    if batch is not None:
        metrics.extend(("seconds", "gflops"))
        for row, fn in timers.items():
            seconds, flops = _time_and_count(fn, cfg.timing_repeats)
            rows[row].update(seconds=mean_ci(seconds), gflops=Estimate(flops / 1e9))
            samples[row]["seconds"] = [float(x) for x in seconds]
        size, tokens = int(batch.shape[0]), int(batch.shape[1])
        notes.append(
            f"Time: mean over {cfg.timing_repeats} timed decodes (after one untimed) of one batch of {size} × {tokens} "
            f"tokens ({tokens * q} frames), the {size} longest clips cropped to the shortest of them; GFLOPs: matrix "
            "products and convolutions of one such decode."
        )
    return _table(
        "reconstruction",
        dataset,
        profile,
        cfg,
        {"clips": len(clips)},
        metrics,
        rows,
        device,
        deterministic=tuple(deterministic),
        notes=[" ".join(notes)],
        samples=samples,
    )


def _phase_metrics(q: int) -> tuple[str, ...]:
    return tuple(f"noise_sjpe_phase{p}" for p in range(q))  # headers: table.metric_label


def _token_phases(joints, gt_joints, q: int) -> dict[str, float]:
    """Noise sJPE by token phase, and phase 0's share of the total (NaN where there is no Noise sJPE at all)."""
    from motionlab.metrics import noise_sjpe_by_phase

    parts = noise_sjpe_by_phase(joints, gt_joints, q)
    total = float(parts.sum())
    share = float(parts[0]) / total if total > 0 else float("nan")
    return {**{f"noise_sjpe_phase{p}": float(x) for p, x in enumerate(parts)}, "noise_sjpe_boundary_share": share}


def _summarize(runs: Sequence[Mapping[str, float]]) -> dict[str, Estimate]:
    """One Estimate per metric over the runs; a metric with a non-finite value is NaN ± NaN rather than an error."""
    out = {}
    for metric in runs[0]:
        values = [float(run[metric]) for run in runs]
        finite = all(np.isfinite(values))
        out[metric] = mean_ci(values) if finite else Estimate(float("nan"), float("nan"), len(values))
    return out


def _timing_batch(normalized: list[np.ndarray], tokenizer):
    from motionlab.flow.reconstruction import timing_batch

    return timing_batch(normalized, tokenizer, TIMING_BATCH)


def _time_and_count(fn: Callable[[], Any], repeats: int) -> tuple[np.ndarray, int]:
    """Seconds of ``repeats`` timed calls of ``fn`` (no gradients, one untimed call first) and its FLOPs."""
    import torch

    from motionlab.flow.reconstruction import count_flops, time_calls

    with torch.no_grad():
        return time_calls(fn, repeats=repeats), count_flops(fn)
