"""The text-to-motion protocol (M2D2M Table 3): R-precision, FID, MM-Dist, Diversity, MultiModality.

One table holds every row the chapters print: "Ground Truth" (the real motions), optionally the VQ-VAE's
reconstruction and the real tokens' statistics, then one row per generating model (``models``, names of
:func:`motionlab.models.load`) and guidance scale (``guidance_scales``). Every generated row is scored with the
same caption draws and generation seeds, so two rows pair up repeat by repeat (:meth:`EvaluationTable.paired`).
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

from motionlab.estimate import Estimate, summarize_runs
from motionlab.profiles import get_profile

from .common import (
    _bar,
    _check_common,
    _check_flow_options,
    _check_int,
    _config,
    _duration,
    _flow_label,
    _FlowSteps,
    _phase,
    _split_clips,
    _table,
    command_line,
    repeat_seed,
)
from .table import R_PRECISION_BATCH, T2M_METRICS, EvaluationTable

DEFAULT_MODEL = "t2m/dynamic"  # the paper's η, training seed 0: the model chapters 07 and 09 share
TOKEN_METRICS = ("hist_tv", "repeat_rate")  # with token_stats: what guidance does to the sampled codes
GROUND_TRUTH, RECONSTRUCTION = "Ground Truth", "VQ-VAE (reconstruction)"

# The text-to-motion names :func:`motionlab.models.load` knows (``t2m/eta<η>``: training seed 0 at any η, for the
# η sweeps beyond the training plan's names).
_MODEL_NAME = re.compile(
    r"^t2m/(?:(?:dynamic|uniform)(?:-seed\d+)?(?:-steps\d+)?|multi-eta0\.25(?:-seed\d+)?"
    r"|distance-(?:l2|cosine|cosine_rank)|eta\d+(?:\.\d+)?)$"
)


def seed_replica(arm: str, seed: int) -> str:
    """The model name of training seed ``seed`` of ``arm`` (``"dynamic"``: the paper's η, ``"uniform"``: η = 0):
    seed 0 is the model every chapter shares (``t2m/dynamic``), others its replicates (``t2m/dynamic-seed1``)."""
    if arm not in ("dynamic", "uniform"):
        raise ValueError(f"arm must be 'dynamic' or 'uniform', got {arm!r}")
    _check_int("seed", seed, 0)
    return f"t2m/{arm}" if seed == 0 else f"t2m/{arm}-seed{int(seed)}"


def eta_model(eta: float) -> str:
    """The model name of dynamic transitions at ``eta`` (training seed 0), by the training plan's name where it has
    one: η = 0 is ``t2m/uniform``, the paper's 0.5 ``t2m/dynamic``, the multi-motion 0.25 ``t2m/multi-eta0.25``."""
    from motionlab.diffusion.training import PAPER_ETA
    from motionlab.multimotion import MULTI_MOTION_ETA

    if isinstance(eta, bool) or not isinstance(eta, (int, float)) or not math.isfinite(eta) or eta < 0:
        raise ValueError(f"eta must be a finite number >= 0, got {eta!r}")
    named = {0.0: "t2m/uniform", PAPER_ETA: "t2m/dynamic", MULTI_MOTION_ETA: "t2m/multi-eta0.25"}
    return named.get(float(eta), f"t2m/eta{float(eta):g}")


def _check_model(name: Any) -> str:
    if not isinstance(name, str) or not _MODEL_NAME.match(name):
        raise ValueError(
            f"unknown text-to-motion model {name!r}; use t2m/dynamic, t2m/uniform, t2m/<arm>-seed<k>[-steps<n>], "
            "t2m/multi-eta0.25[-seed<k>], t2m/distance-{l2,cosine,cosine_rank} or t2m/eta<η>"
        )
    return name


def _scale(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class TextToMotionConfig:
    """The text-to-motion protocol.

    ``models``: the generating models by their :func:`motionlab.models.load` names, one row each (several share the
    Ground Truth row, the caption draws and the generation seeds). ``guidance_scales``: one row per scale and model
    (empty: one row at ``guidance_scale``, None: the model's s = 4). ``num_steps`` (None: all T) and ``top_p``
    (None: no truncation) go to the sampler, and so does ``guidance_on``: where guidance acts, on p_θ(x_0 | x_t)
    (``"x0"``, VQ-Diffusion's code) or on p_θ(x_{t-1} | x_t) (``"posterior"``, M2D2M's Eq. 9). ``decoder``:
    ``"vq"`` or ``"discord"`` (the VQ tokens decoded by DisCoRD). ``reconstruction`` adds the VQ-VAE's
    reconstruction of the real motions (the ceiling of any token generator with this tokenizer); ``token_stats``
    adds, per generated row and repeat, the code-histogram TV of the sampled tokens to the real ones and their
    adjacent-repeat rate, and a "Real tokens" row (the TV of another split's tokens: the floor two real samples
    reach). MultiModality (when ``multimodality``) generates each of the
    first ``mm_texts`` captions ``mm_repeats`` times per repeat (the T2M protocol: 100 × 30).
    """

    decoder: str = "vq"
    steps: int | None = None
    solver: str | None = None
    num_steps: int | None = None
    guidance_scale: float | None = None
    multimodality: bool = False
    mm_texts: int = 100
    mm_repeats: int = 30
    split: str = "test"
    limit: int | None = None
    repeats: int = 1
    seed: int = 0
    models: tuple[str, ...] = (DEFAULT_MODEL,)
    guidance_scales: tuple[float, ...] = ()
    top_p: float | None = None
    guidance_on: str = "x0"
    reconstruction: bool = False
    token_stats: bool = False

    def __post_init__(self):
        if self.decoder not in ("vq", "discord"):
            raise ValueError(
                f"decoder must be 'vq' or 'discord' (the diffusion model samples VQ tokens), got {self.decoder!r}"
            )
        _check_flow_options(self, self.decoder == "discord")
        _check_common(self, R_PRECISION_BATCH, f" (R-precision ranks batches of {R_PRECISION_BATCH} clips)")
        if self.num_steps is not None:
            _check_int("num_steps", self.num_steps, 1)
        _check_int("mm_texts", self.mm_texts, 2)
        _check_int("mm_repeats", self.mm_repeats, 10, " (10 pairs are drawn among them)")
        models = (self.models,) if isinstance(self.models, str) else tuple(self.models)
        if not models or len(set(models)) != len(models):
            raise ValueError(f"models must be one or more distinct model names, got {self.models!r}")
        object.__setattr__(self, "models", tuple(_check_model(m) for m in models))  # a list becomes a tuple
        scales = tuple(_scale(s, "each guidance scale") for s in self.guidance_scales)
        if len(set(scales)) != len(scales):
            raise ValueError(f"guidance_scales must be distinct, got {self.guidance_scales!r}")
        if scales and self.guidance_scale is not None:
            raise ValueError("give guidance_scale (one s for every row) or guidance_scales (a row per s), not both")
        object.__setattr__(self, "guidance_scales", scales)
        if self.guidance_scale is not None:
            object.__setattr__(self, "guidance_scale", _scale(self.guidance_scale, "guidance_scale"))
        from motionlab.diffusion.sampling import check_guidance_space

        check_guidance_space(self.guidance_on)
        top_p = self.top_p
        if top_p is not None and (isinstance(top_p, bool) or not isinstance(top_p, (int, float)) or not 0 < top_p <= 1):
            raise ValueError(f"top_p must be in (0, 1], got {self.top_p!r}")
        for flag in ("multimodality", "reconstruction", "token_stats"):
            if not isinstance(getattr(self, flag), bool):
                raise ValueError(f"{flag} must be True or False, got {getattr(self, flag)!r}")

    @classmethod
    def from_sizes(cls, sizes: Any, **options: Any) -> TextToMotionConfig:
        """The evaluation a chapter runs, from its sizes (:mod:`motionlab.sizes`); ``options`` override fields.

        ``sizes.diffusion`` (chapter 07, M2D2M Table 3 and the guidance sweep): the shared model at every scale of
        ``guidance_scales``, with the VQ-VAE reconstruction, MultiModality and the token statistics.
        ``sizes.transitions`` (chapter 08): every model of its design at s = ``guidance_scale`` -- both arms at each
        training seed (``seed_replica``), then the η sweep (``eta_model``), then the distance ablation if chosen.
        """
        from motionlab.models import DISTANCES
        from motionlab.sizes import DiffusionSizes, TransitionsSizes

        if not isinstance(sizes, (DiffusionSizes, TransitionsSizes)):
            raise ValueError(f"sizes must be DiffusionSizes or TransitionsSizes, got {type(sizes).__name__}")
        common = dict(limit=sizes.eval_clips, repeats=sizes.repeats, num_steps=sizes.num_steps)
        if isinstance(sizes, DiffusionSizes):
            chosen = dict(
                guidance_scales=sizes.guidance_scales,
                multimodality=True,
                mm_texts=sizes.mm_texts,
                mm_repeats=sizes.mm_repeats,
                reconstruction=True,
                token_stats=True,
            )
        else:
            models = [seed_replica(arm, s) for arm in ("uniform", "dynamic") for s in sizes.training_seeds]
            models += [eta_model(eta) for eta in sizes.sweep_etas]
            models += [f"t2m/distance-{d}" for d in DISTANCES] if sizes.distance_ablation else []
            chosen = dict(models=tuple(dict.fromkeys(models)), guidance_scale=sizes.guidance_scale)
        unknown = sorted(set(options) - {f.name for f in fields(cls)})
        if unknown:
            raise ValueError(f"unknown TextToMotionConfig option(s): {', '.join(unknown)}")
        return cls(**{**common, **chosen, **options})

    def row(self, model: str, scale: float | None = None, decoder_name: str = "VQ decoder") -> str:
        """The table's row name of ``model`` at guidance ``scale``: what tells the rows apart (the model, if not the
        default alone; ``s``, if several; top-p), e.g. ``"s = 4"``, ``"t2m/uniform-seed1"``; the default model at
        one scale is ``"Discrete diffusion + VQ decoder"``."""
        parts = [model] if self.models != (DEFAULT_MODEL,) else []
        parts += [f"s = {scale:g}"] if self.guidance_scales else []
        parts += [f"top-p {self.top_p:g}"] if self.top_p is not None else []
        if not parts:
            return f"Discrete diffusion + {decoder_name}"
        return ", ".join(parts) + (f" + {decoder_name}" if self.decoder == "discord" else "")

    def command_line(self, profile: str | None = None) -> str:
        """The ``motionlab evaluate t2m`` command that computes this table (see :func:`command_line`)."""
        return command_line(self, "t2m", profile)

    def real_tokens_row(self) -> str:
        """The row name of the real tokens' statistics (with ``token_stats``)."""
        return f"Real tokens ({_other_split(self.split)} vs {self.split})"


def _other_split(split: str) -> str:
    # the split whose tokens give the TV floor: two real samples of the same size
    return "test" if split == "train" else "train"


def _load_model(name: str, dataset, profile: str, device: str | None):
    """A text-to-motion pipeline by name (:func:`motionlab.models.load`)."""
    from motionlab import models

    return models.load(name, dataset, profile, device=device)


def evaluate_t2m(
    dataset,
    config: TextToMotionConfig | None = None,
    profile: str | None = None,
    *,
    device: str | None = None,
    progress: bool = False,
) -> EvaluationTable:
    """The text-to-motion protocol on ``config.split``: a "Ground Truth" row (the real motions scored against
    drawn captions) and one row per model and guidance scale, each over ``config.repeats`` caption draws /
    generations (:func:`~motionlab.diffusion.pipeline.evaluate_text_to_motion`; repeat r: captions
    ``default_rng([seed, r])``, generation seed ``1000·seed + r``, the same for every row). MultiModality repeat r
    generates from ``repeat_seed(seed, r, 1)``. ``table.samples`` keeps each row's per-repeat values.
    """
    from motionlab.diffusion.diagnostics import TokenRecorder, token_statistics
    from motionlab.diffusion.pipeline import evaluate_fixed_motions, evaluate_ground_truth, evaluate_text_to_motion
    from motionlab.diffusion.training import tokenize_clips
    from motionlab.metrics.evaluator_training import load_or_train_evaluator

    cfg = _config(config, TextToMotionConfig)
    profile = get_profile(profile)
    clips = _split_clips(dataset, cfg.split, cfg.limit, R_PRECISION_BATCH, "R-precision (batches of 32)")
    scales = cfg.guidance_scales or (cfg.guidance_scale,)
    n_rows = len(cfg.models) * len(scales)
    _phase(
        f"t2m: {len(clips)} {cfg.split} clips, {n_rows} generated row{'s' if n_rows > 1 else ''}; loading (or "
        "training) the evaluator and the diffusion models"
    )
    evaluator = load_or_train_evaluator(dataset, profile, device=device, progress=progress)
    mm_clips = clips[: cfg.mm_texts]
    mm_motions = len(mm_clips) * cfg.mm_repeats  # per repeat, vs len(clips) for the protocol itself
    # The bar counts generated motions, so its ETA stays honest when the (much longer) MultiModality starts.
    per_row = cfg.repeats * (len(clips) + (mm_motions if cfg.multimodality else 0))
    bar = _bar(n_rows * per_row, "t2m generations", progress, unit="motion")
    timing = {"motions": 0, "seconds": 0.0}
    runs: dict[str, list[dict[str, float]]] = {}  # per row, one metrics dict per repeat (in table order)
    fixed: dict[str, dict[str, float]] = {}  # rows measured once (the real tokens)
    decoder, decoder_name = None, "VQ decoder"
    with bar:
        runs[GROUND_TRUTH] = evaluate_ground_truth(evaluator, clips, repeats=cfg.repeats, seed=cfg.seed)
        for m, model in enumerate(cfg.models):
            pipe = _load_model(model, dataset, profile, device)
            K = pipe.tokenizer.codebook_size
            if m == 0:  # what every model shares: the VQ tokenizer, hence its decoders and the real tokens
                if cfg.decoder == "discord":
                    from motionlab import models

                    flow = models.load("discord/vq", dataset, profile, device=device)  # of the pipeline's VQ tokens
                    decoder = _FlowSteps(flow, cfg.steps, cfg.solver)
                    decoder_name = f"DisCoRD ({_flow_label(flow, cfg.steps, cfg.solver)})"
                if cfg.reconstruction:
                    motions = pipe.reconstruct(clips)
                    runs[RECONSTRUCTION] = evaluate_fixed_motions(
                        evaluator, clips, motions, repeats=cfg.repeats, seed=cfg.seed
                    )
                if cfg.token_stats:
                    real_ids = tokenize_clips(pipe.tokenizer, [dataset.normalizer.normalize(c.features) for c in clips])
                    other = tokenize_clips(pipe.tokenizer, dataset.normalized(_other_split(cfg.split))[: len(clips)])
                    fixed[cfg.real_tokens_row()] = {
                        "hist_tv": token_statistics(other, real_ids, K)["hist_tv"],
                        "repeat_rate": token_statistics(real_ids, real_ids, K)["repeat_rate"],
                    }
            for scale in scales:
                label = cfg.row(model, scale, decoder_name)
                sampling = {
                    "num_steps": cfg.num_steps,
                    "guidance_scale": scale,
                    "guidance_on": cfg.guidance_on,
                    "top_p": cfg.top_p,
                }
                sampling = {k: v for k, v in sampling.items() if v is not None}
                where = f" for {label}" if n_rows > 1 else ""
                recorder = TokenRecorder(pipe)  # keeps the sampled ids: the token statistics of the same samples
                generate = _timed(recorder, decoder, timing, bar, cfg.repeats, where)
                row = evaluate_text_to_motion(
                    generate, evaluator, clips, repeats=cfg.repeats, seed=cfg.seed, **sampling
                )
                if cfg.multimodality:
                    _multimodality(pipe, evaluator, mm_clips, row, cfg, timing, bar, decoder, sampling, where)
                if cfg.token_stats:
                    for run, ids in zip(row, recorder.tokens, strict=True):
                        run.update(token_statistics(ids, real_ids, K))
                runs[label] = row
            del pipe  # one model in memory at a time
    metrics = (T2M_METRICS if cfg.multimodality else T2M_METRICS[:-1]) + (TOKEN_METRICS if cfg.token_stats else ())
    rows = {name: summarize_runs(r) for name, r in runs.items()}
    fixed_rows = {name: {k: Estimate(v) for k, v in cells.items()} for name, cells in fixed.items()}
    first = 2 if cfg.reconstruction else 1  # the fixed rows follow the real motions and their reconstruction
    ordered = dict(list(rows.items())[:first]) | fixed_rows | dict(list(rows.items())[first:])
    samples = {name: {k: [float(run[k]) for run in r] for k in r[0]} for name, r in runs.items()}
    counts = {"clips": len(clips), **({"multimodality texts": len(mm_clips)} if cfg.multimodality else {})}
    table = _table(
        "t2m", dataset, profile, cfg, counts, metrics, ordered, device, deterministic=tuple(fixed), samples=samples
    )
    table.notes.append(_sampling_note(cfg, decoder_name))
    return table


ARMS = ("uniform", "dynamic")  # chapter 08's arms: η = 0 (VQ-Diffusion) and the paper's η


@dataclass(frozen=True)
class ArmsComparison:
    """Dynamic against uniform transitions (M2D2M Table 3) from a table that scored both arms, with the variance
    between training runs where it was measured (:func:`compare_arms`).

    ``fid``/``top3``: each arm's number, the mean over the table's training seeds (Student's t over the seeds) or, at
    one seed, that model's (its repeats' interval). ``same_seed``: dynamic − uniform FID at training seed 0, paired per
    repeat (the evaluation's noise only). ``seed_gaps``: per arm, FID of one training seed − another, the pair named by
    ``gap_label`` (``"seed 1 − seed 0"``), measured as ``gap_source`` says (paired per repeat when the table has both;
    the study's numbers, without an interval, otherwise). ``training``: dynamic − uniform FID over training runs (the
    mean over the table's seeds with t over them, or, the claims table's rule, seed 0's paired difference averaged
    with the study's other runs, :meth:`~motionlab.comparison.RunDifferences.pooled`); None where neither was
    measured. ``source`` says which runs.
    """

    fid: dict[str, Estimate]
    top3: dict[str, Estimate]
    same_seed: Estimate
    seed_gaps: dict[str, Estimate]
    gap_label: str
    gap_source: str
    training: Estimate | None
    source: str


def compare_arms(table: EvaluationTable, seeds: tuple[int, ...] = (0,), spread: Any = None) -> ArmsComparison:
    """Chapter 08's comparison of the two arms in ``table`` (rows named by :func:`seed_replica`) at training ``seeds``
    (seed 0 first). With one seed the training variance comes from ``spread``, the training-seed study
    (:func:`motionlab.report.load_spread`, keys ``transitions/fid_dynamic`` and ``transitions/fid_uniform``)."""
    from motionlab.estimate import mean_ci

    seeds = tuple(int(s) for s in seeds)
    if not seeds or seeds[0] != 0 or len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be distinct and start with 0, got {seeds}")
    same_seed = table.paired(seed_replica("dynamic", 0), seed_replica("uniform", 0), "fid")
    if len(seeds) > 1:  # replicates in the table: the training variance measured here
        per_seed = {
            m: {a: [table.estimate(seed_replica(a, s), m).mean for s in seeds] for a in ARMS} for m in ("fid", "top3")
        }
        return ArmsComparison(
            fid={a: mean_ci(v) for a, v in per_seed["fid"].items()},
            top3={a: mean_ci(v) for a, v in per_seed["top3"].items()},
            same_seed=same_seed,
            seed_gaps={a: table.paired(seed_replica(a, seeds[1]), seed_replica(a, 0), "fid") for a in ARMS},
            gap_label=f"seed {seeds[1]} − seed 0",
            gap_source="paired per repeat",
            training=mean_ci(
                [d - u for d, u in zip(per_seed["fid"]["dynamic"], per_seed["fid"]["uniform"], strict=True)]
            ),
            source=f"the mean over {len(seeds)} training seeds per arm, trained and scored here",
        )
    fid = {a: table.estimate(seed_replica(a, 0), "fid") for a in ARMS}
    top3 = {a: table.estimate(seed_replica(a, 0), "top3") for a in ARMS}
    keys = ("transitions/fid_dynamic", "transitions/fid_uniform")
    from motionlab.comparison import this_build

    others = spread.other_runs(*keys, this_build()) if spread is not None else None
    if others is None:
        return ArmsComparison(
            fid, top3, same_seed, {}, "", "", None, "training seed 0 only: no training-seed study on this data"
        )
    study = spread.runs(*keys)  # sorted, at least MIN_SEEDS of them
    gaps = {
        a: Estimate(spread.values[f"transitions/fid_{a}"][study[1]] - spread.values[f"transitions/fid_{a}"][study[0]])
        for a in ARMS
    }
    # the claims table's rule: seed 0's paired difference averaged with the study's other runs of the two arms
    training = others.pooled(same_seed)
    source = (
        f"the mean over {training.n} training runs: this build's and the study's {', '.join(map(str, others.runs))}"
    )
    # two runs in different precisions differ in more than the seed: the label then names both
    same = study[0].precision == study[1].precision
    label = f"seed {study[1].seed} − seed {study[0].seed}" if same else f"{study[1]} − {study[0]}"
    how = "the training-seed study's numbers"
    return ArmsComparison(fid, top3, same_seed, gaps, label, how, training, source)


def _timed(recorder, decoder, timing: dict, bar, repeats: int, where: str) -> Callable:
    """The protocol's ``generate``: the recorder's generation with the decoder, timed and counted on the bar."""
    timing["row"] = 0

    def generate(texts, lengths, *, seed, **kw):
        timing["row"] += 1
        _phase(f"generating {len(texts)} motions (repeat {timing['row']} of {repeats}){where}")
        start = time.perf_counter()
        motions = recorder(texts, lengths, seed=seed, decoder=decoder, **kw)
        timing["seconds"] += time.perf_counter() - start
        timing["motions"] += len(texts)
        bar.update(len(texts))
        return motions

    return generate


def _multimodality(pipe, evaluator, mm_clips, runs, cfg, timing, bar, decoder, sampling, where: str) -> None:
    """MultiModality of one row, once per repeat (seed ``repeat_seed(seed, r, 1)``), into ``runs[r]``."""
    from motionlab.diffusion.pipeline import multimodality_score

    mm_motions = len(mm_clips) * cfg.mm_repeats
    per_motion = timing["seconds"] / max(timing["motions"], 1)
    _phase(
        f"MultiModality: {cfg.repeats} × {mm_motions} motions ({len(mm_clips)} texts × {cfg.mm_repeats}), "
        f"about {_duration(cfg.repeats * mm_motions * per_motion)} at the "
        f"{per_motion:.2f} s per motion measured so far{where}"
    )
    for r, run in enumerate(runs):
        _phase(f"MultiModality repeat {r + 1} of {cfg.repeats}{where}")
        run["multimodality"] = multimodality_score(
            pipe,
            evaluator,
            mm_clips,
            n_repeats=cfg.mm_repeats,
            seed=repeat_seed(cfg.seed, r, 1),
            decoder=decoder,
            **sampling,
        )
        bar.update(mm_motions)


def _sampling_note(cfg: TextToMotionConfig, decoder_name: str) -> str:
    """One line under the table: which models, how they sampled, how they were decoded."""
    if cfg.guidance_scales:
        scale = "s as in each row"
    elif cfg.guidance_scale is None:
        scale = "the model's guidance scale (s = 4)"
    else:
        scale = f"s = {cfg.guidance_scale:g}"
    steps = "all T sampling steps" if cfg.num_steps is None else f"{cfg.num_steps} sampling steps"
    top_p = f", top-p {cfg.top_p:g}" if cfg.top_p is not None else ""
    space = ", guidance on p_θ(x_{t-1} | x_t) (Eq. 9)" if cfg.guidance_on == "posterior" else ""
    return f"Generated by {', '.join(cfg.models)}: {scale}{space}, {steps}{top_p}, decoded by the {decoder_name}."


__all__ = [
    "ARMS",
    "DEFAULT_MODEL",
    "TOKEN_METRICS",
    "ArmsComparison",
    "TextToMotionConfig",
    "compare_arms",
    "eta_model",
    "evaluate_t2m",
    "seed_replica",
]
