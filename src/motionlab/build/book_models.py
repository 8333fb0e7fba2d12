"""Every model the book's chapters load, as one plan: what to train, in which order, how long it takes.

``motionlab train book`` runs this plan (see :mod:`motionlab.build.plan`) before the chapters execute, so a
chapter only loads from the cache. Each job's recipe is :func:`motionlab.models.load` of the job's name, the
*same call* a chapter makes, so the cache keys agree by construction; a test checks that the chapters find
everything cached after the plan ran.

    data ─┬─ tokenizer/vq ──┬─ t2m/dynamic, t2m/uniform           (chapters 07, 08, 09)
          │                 ├─ t2m/multi-eta0.25                   (chapters 08, 09)
          │                 ├─ t2m/{dynamic,uniform}-seed{1,2}     (chapter 08's training-seed control; smoke, full)
          │                 └─ discord/vq                          (chapter 09)
          ├─ tokenizer/rvq ─┬─ discord/rvq, discord/rvq-xpred      (chapter 05)
          │                 └─ discord/rvq-{stacked,repeat,transposed} (chapter 04)
          └─ evaluator                                             (chapters 05–09)
    toy_flow/ring, toy_flow/ring-conditional                       (chapter 03)

``discord/rvq`` is chapter 05's decoder, the one DisCoRD's claims are judged on; it gets the profile's whole flow
budget. Chapter 04's three projections compare with each other, not with the feed-forward decoder, and chapter 09's
``discord/vq`` carries no claim, so in the laptop profile those four train under a third of its steps at half its width
(``DISCORD_ABLATION`` and ``DISCORD_VQ`` in :mod:`motionlab.sizes`, where the reasons are).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

from .. import models
from ..models import book_dataset
from ..profiles import get_profile
from ..sizes import chapter_sizes
from ..train.cache import NotCached, cache_probe
from .plan import Job

# Training CPU seconds per model on one core of the reference machine, the slowest CPU of this project's kind (an
# AMD EPYC Zen 3 with AVX2 only, 2 cores, two 1-thread workers, fp32), from `motionlab train book --record`
# (book/data/build_times/laptop-training.json; laptop: a tokenizer step 0.15 s x 2,000, a DisCoRD step 0.31 s x 4,000
# for chapter 05's decoder and 0.15 s x 1,150 for the short, narrow decoders of chapter 04's ablation and chapter 09's
# VQ tokens, a diffusion step 0.19 s x 800). Faster CPUs finish sooner; the numbers drive the plan line and the progress
# estimates, nothing else.
ESTIMATES_S: dict[str, dict[str, float]] = {
    "smoke": {
        "data": 8,
        "tokenizer": 10,
        "toy_flow": 5,
        "evaluator": 10,
        "discord": 10,
        "discord_short": 10,
        "t2m": 15,
    },
    "laptop": {
        "data": 60,
        "tokenizer": 305,
        "toy_flow": 25,
        "evaluator": 150,
        "discord": 1240,
        "discord_short": 170,
        "t2m": 160,
    },
    "full": {
        "data": 1500,
        "tokenizer": 36_000,
        "toy_flow": 300,
        "evaluator": 36_000,
        "discord": 360_000,
        "discord_short": 360_000,
        "t2m": 180_000,
    },
}

# A bf16 run's training time is the fp32 estimate over this factor: the CPU-time ratio of whole laptop trainings, fp32
# vs bf16 side by side on an AMD EPYC with AVX512-BF16 and no AMX (experiments/precision_parity.py, 2026-12-02; the
# same steps timed alone by benchmarks/bench_train.py: tokenizers 1.27-1.39x, DisCoRD 1.34x, diffusion 1.38x). The
# evaluator always trains in fp32 (motionlab.metrics.evaluator_training.EVALUATOR_PRECISION).
BF16_SPEEDUP: dict[str, float] = {
    "data": 1.0,
    "tokenizer": 1.37,
    "toy_flow": 1.0,
    "evaluator": 1.0,
    "discord": 1.24,
    "discord_short": 1.24,
    "t2m": 1.22,
}


# The laptop models in bf16, measured: seconds per model of each kind, the largest over the cold builds recorded on the
# slowest CPU measured in bf16, an AMD EPYC Zen 4 with AVX512-BF16 (two 1-thread workers; history/1193b88-, 79de014-
# and 265de6d-zen4-bf16-training.json under book/data/build_times, three machines of the kind). Wall seconds, starting
# the worker included: a reader waits for those. The fp32 estimates over BF16_SPEEDUP said 1,000 s for chapter 05's
# decoder, which took 610-693 s there: Zen 3, the fp32 reference, is also the slower CPU in fp32, which the speed-up
# (measured on one CPU in both precisions) leaves out, and the plan line promised about 31 min of training where
# 21-23 passed.
MEASURED_BF16_S: dict[str, dict[str, float]] = {
    "laptop": {
        "data": 50,
        "tokenizer": 166,
        "toy_flow": 31,
        "evaluator": 102,
        "discord": 693,
        "discord_short": 122,
        "t2m": 148,
    },
}


def compile_estimate(name: str, device, precision: str, run) -> float | None:
    """Seconds the book's model ``name`` spends compiling before it trains on ``device`` under the run's compile
    setting: 0 where nothing compiles, the compile time ``run`` (a GPU benchmark's run, or None) measured, None where
    it compiles and nothing measured how long (on a CPU the compile time was never recorded)."""
    from ..train.compiling import GRAPHED, compile_mode

    part, bench = models.compiled_part(name), models.benchmark_model(name)
    mode = compile_mode(part, device) if part is not None else None
    if mode is None:
        return 0.0
    return None if run is None or bench is None else run.compile_seconds(bench, precision, mode == GRAPHED)


def job_precision(name: str, run_precision: str) -> str:
    """The precision the book's model ``name`` trains in when the run's is ``run_precision``: the run's, except for
    the evaluator, which always trains in fp32."""
    from ..metrics.evaluator_training import EVALUATOR_PRECISION

    return EVALUATOR_PRECISION if name == "evaluator" else run_precision


def training_estimates(profile: str, precision: str) -> dict[str, float]:
    """Training seconds per kind of model for ``profile`` trained in ``precision`` (``fp32`` | ``bf16``): the
    slowest CPU measured in that precision where a build measured it (wall seconds, :data:`MEASURED_BF16_S`), else
    the fp32 CPU seconds of :data:`ESTIMATES_S`, over the speed-up in bf16."""
    profile = get_profile(profile)
    cost = ESTIMATES_S[profile]
    if precision == "fp32":
        return dict(cost)
    if profile in MEASURED_BF16_S:
        return dict(MEASURED_BF16_S[profile])
    return {kind: seconds / BF16_SPEEDUP[kind] for kind, seconds in cost.items()}


# -- recipes: module-level so worker processes can unpickle them --------------------------------------------------
# Every recipe takes the profile, the data seed and ``data`` (a dataset folder; None: the embedded dataset).
def make_data(profile: str, seed: int, data: str | None = None) -> None:
    book_dataset(profile, seed, data)


def make_model(profile: str, seed: int, name: str, data: str | None = None, overrides: dict | None = None) -> None:
    """Train (or find cached) the book's model ``name``: :func:`motionlab.models.load`, the call a chapter makes.

    ``seed`` is the data seed and a DisCoRD decoder's or toy flow's training seed; ``overrides`` change a DisCoRD
    decoder's config. The toy flows never read motion, so they do not load the dataset.
    """
    dataset = None if name.startswith("toy_flow/") else book_dataset(profile, seed, data)
    models.load(name, dataset, profile, seed=seed, **(overrides or {}))


# -- the plan ------------------------------------------------------------------------------------------------------
def is_cached(run) -> bool:
    """Whether ``run()`` would only load: it runs under :func:`~motionlab.train.cache.cache_probe`."""
    with cache_probe():
        try:
            run()
        except NotCached:
            return False
    return True


def book_jobs(
    profile: str | None = None,
    seed: int = 0,
    *,
    data: str | None = None,
    flow_options: dict | None = None,
    precision: str | None = None,
) -> list[Job]:
    """The book's models for ``profile``, in a valid training order (inputs first).

    ``data`` trains them on a dataset folder instead of the embedded data; ``flow_options`` override the
    config of the two ``stacked`` DisCoRD decoders (what ``train discord --predict ...`` does). The jobs' time
    estimates are for ``precision`` (default: what this machine trains in).
    """
    from ..precision import network_precision
    from ..report.gpu import newest_gpu_run
    from ..train.device import get_device

    profile = get_profile(profile)
    device = get_device(None)
    precision = precision or network_precision(device)
    cost = training_estimates(profile, precision)
    gpu_run = newest_gpu_run() if device.type == "cuda" else None  # what compiling took there
    on = {"data": data}

    def job(name: str, kind: str, after: tuple[str, ...] = (), **kwargs) -> Job:
        if name == "data":
            run = partial(make_data, profile, seed, **on)
        else:
            run = partial(make_model, profile, seed, name, **on, **kwargs)
        compiling = compile_estimate(name, device, precision, gpu_run)
        return Job(name, run, after, cost[kind], partial(is_cached, run), compiling)

    vq, rvq, flow = ("tokenizer/vq",), ("tokenizer/rvq",), {"overrides": flow_options}
    replicates = chapter_sizes(profile).transitions.training_seeds[1:]
    return [
        job("data", "data"),
        # longest chains first, so the greedy scheduler starts them early
        job("tokenizer/rvq", "tokenizer", ("data",)),
        job("tokenizer/vq", "tokenizer", ("data",)),
        job("discord/rvq", "discord", rvq, **flow),
        job("discord/rvq-xpred", "discord", rvq, **flow),
        job("discord/vq", "discord_short", vq, **flow),
        job("t2m/dynamic", "t2m", vq),
        job("t2m/uniform", "t2m", vq),
        job("t2m/multi-eta0.25", "t2m", vq),
        # chapter 08's training-seed replicates where its profile trains them (seed 0 of each arm is the pair above)
        *(job(f"t2m/{arm}-seed{k}", "t2m", vq) for k in replicates for arm in ("dynamic", "uniform")),
        *(job(f"discord/rvq-{p}", "discord_short", rvq) for p in ("stacked", "repeat", "transposed")),
        # chapter 08's distance ablation
        *(job(f"t2m/distance-{d}", "t2m", vq) for d in ("l2", "cosine", "cosine_rank") if profile == "full"),
        job("evaluator", "evaluator", ("data",)),
        job("toy_flow/ring", "toy_flow"),
        job("toy_flow/ring-conditional", "toy_flow"),
    ]


# The models each chapter loads (names of :func:`book_jobs`, laptop and smoke plans; chapter 08's seed replicates only
# where the profile's sizes train them); the intro's chapter map charges a model's training to the first chapter, in
# book order, that loads it.
CHAPTER_MODELS: dict[str, tuple[str, ...]] = {
    "01_motion_data": ("data",),
    "02_vector_quantization": ("data", "tokenizer/vq", "tokenizer/rvq"),
    "03_rectified_flow": ("toy_flow/ring", "toy_flow/ring-conditional"),
    "04_condition_projection": (
        "data",
        "tokenizer/rvq",
        "discord/rvq-stacked",
        "discord/rvq-repeat",
        "discord/rvq-transposed",
    ),
    "05_discord": ("data", "tokenizer/rvq", "discord/rvq", "discord/rvq-xpred", "evaluator"),
    "06_sjpe": ("data", "evaluator"),
    "07_discrete_diffusion": ("data", "tokenizer/vq", "t2m/dynamic", "evaluator"),
    "08_dynamic_transitions": (
        "data",
        "tokenizer/vq",
        "t2m/dynamic",
        "t2m/uniform",
        "t2m/multi-eta0.25",
        "t2m/dynamic-seed1",
        "t2m/uniform-seed1",
        "t2m/dynamic-seed2",
        "t2m/uniform-seed2",
        "evaluator",
    ),
    "09_two_phase_sampling": ("data", "tokenizer/vq", "t2m/uniform", "t2m/multi-eta0.25", "discord/vq", "evaluator"),
    "98_full_scale": (),
    "99_what_reproduces": (),
    "s1_decoder_sweep": ("data", "tokenizer/rvq", "discord/rvq"),
    "s2_training_budgets": (),  # reads the recorded studies, trains nothing
    "s3_retraining": (),
    "s4_bf16_vs_fp32": (),
    "s5_dead_codes": (),
    "s6_judging_verdicts": (),  # judges the chapters' recorded numbers, trains nothing
    "s7_departures": (),  # reads the configs, the recorded numbers and the committed studies
}


def chapter_costs(training: dict[str, dict], execution: dict[str, dict]) -> dict[str, tuple[float, float]]:
    """``{chapter: (cold, warm)}`` in seconds, in book order, from recorded build times.

    ``training`` maps a model to its record, ``execution`` a chapter to its; both give wall ``seconds`` (a job
    or chapter runs on one core of its own). Warm is the chapter's execution with every model cached; cold adds
    the training of the models that no earlier chapter loads (reading the book in order from an empty cache).
    """
    seen: set[str] = set()
    costs = {}
    for chapter, names in CHAPTER_MODELS.items():
        if chapter not in execution:
            continue
        new = [m for m in names if m not in seen]
        seen.update(names)
        warm = float(execution[chapter]["seconds"])
        costs[chapter] = (warm + sum(float(training.get(m, {}).get("seconds", 0.0)) for m in new), warm)
    return costs


def jobs_for(names: Sequence[str], profile: str | None = None, **kwargs) -> list[Job]:
    """The named jobs of :func:`book_jobs` and every job they need, in plan order (what one command needs)."""
    jobs = {job.name: job for job in book_jobs(profile, **kwargs)}
    unknown = sorted(set(names) - set(jobs))
    if unknown:
        raise ValueError(f"unknown models {unknown}; the plan has {sorted(jobs)}")
    needed, todo = set(), list(names)
    while todo:
        name = todo.pop()
        if name not in needed:
            needed.add(name)
            todo.extend(jobs[name].after)
    return [job for name, job in jobs.items() if name in needed]


__all__ = [
    "BF16_SPEEDUP",
    "CHAPTER_MODELS",
    "ESTIMATES_S",
    "MEASURED_BF16_S",
    "book_jobs",
    "chapter_costs",
    "is_cached",
    "job_precision",
    "jobs_for",
    "training_estimates",
]
