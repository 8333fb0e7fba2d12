"""Every model the book's chapters load, as one plan: what to train, in which order, how long it takes.

``motionlab train book`` runs this plan (see :mod:`motionlab.train.plan`) before the chapters execute, so a
chapter only loads from the cache. Each recipe below makes the *same call* a chapter makes (same function,
same profile, same config), so the cache keys agree by construction; a test checks that the chapters find
everything cached after the plan ran.

    data ─┬─ tokenizer/vq ──┬─ t2m/dynamic, t2m/uniform           (chapters 07, 08, 09)
          │                 ├─ t2m/multi-eta0.25                   (chapters 08, 09)
          │                 ├─ t2m/dynamic-seed1, t2m/uniform-seed1 (chapter 08's training-seed control)
          │                 └─ discord/vq                          (chapter 09)
          ├─ tokenizer/rvq ─┬─ discord/rvq                         (chapters 05, 06)
          │                 └─ ablation/stacked, ablation/repeat,
          │                    ablation/transposed                 (chapter 04)
          └─ evaluator                                             (chapters 05–09)
    toy_flow/ring, toy_flow/ring-conditional                       (chapter 03)

One flow decoder per token type serves every chapter that decodes those tokens. Chapter 04's projection ablation
trains its three decoders at :data:`ABLATION_BUDGET` of that decoder's steps: the three must share one budget, and
three full-budget decoders were a quarter of the laptop build's training for a comparison whose verdict ("no clear
difference at this scale") did not change with the budget. In the ``full`` profile the ablation's ``stacked``
decoder *is* chapter 05's, and the plan trains it once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from functools import lru_cache, partial

from .diffusion.training import PAPER_ETA
from .multimotion import MULTI_MOTION_ETA
from .profiles import get_profile
from .train.cache import NotCached, cache_probe
from .train.plan import Job

# Training CPU seconds per model on one core of the reference machine (2 cores, two 1-thread workers), from
# `motionlab train book` (laptop: a tokenizer step 0.26 s x 2,000, a DisCoRD step 0.54 s x 1,150, the ablation's
# 288 such steps, a diffusion step 0.42 s x 800); they drive the plan line and the progress estimates, nothing else.
ESTIMATES_S: dict[str, dict[str, float]] = {
    "smoke": {"data": 8, "tokenizer": 10, "toy_flow": 5, "evaluator": 10, "discord": 10, "ablation": 5, "t2m": 15},
    "laptop": {"data": 150, "tokenizer": 520, "toy_flow": 90, "evaluator": 200, "discord": 620, "ablation": 160,
               "t2m": 340},
    "full": {"data": 1500, "tokenizer": 36_000, "toy_flow": 300, "evaluator": 36_000, "discord": 360_000,
             "ablation": 360_000, "t2m": 180_000},
}  # fmt: skip


# -- recipes: module-level so worker processes can unpickle them --------------------------------------------------
# Every recipe takes the profile, the data seed and ``data`` (a dataset folder; None: the embedded dataset).
@lru_cache(maxsize=4)  # the plan's cache checks share one loaded dataset
def _dataset(profile: str, seed: int, data: str | None = None):
    from .data import load_dataset

    return load_dataset(data, profile=profile, seed=seed)


def make_data(profile: str, seed: int, data: str | None = None) -> None:
    _dataset(profile, seed, data)


def make_tokenizer(profile: str, seed: int, kind: str, data: str | None = None) -> None:
    from .tokenizers import tokenizer_for_dataset

    tokenizer_for_dataset(kind, _dataset(profile, seed, data), profile)


def make_toy_flow(profile: str, seed: int, conditional: bool, data: str | None = None) -> None:
    """Chapter 03's 2-D toy flows (``data`` is accepted for a uniform signature; they never read motion)."""
    from .flow.toy import toy_flow_config, train_or_load_toy_flow

    train_or_load_toy_flow(toy_flow_config(profile, distribution="ring", conditional=conditional, seed=seed),
                           profile=profile)  # fmt: skip


def make_evaluator(profile: str, seed: int, data: str | None = None) -> None:
    from .metrics.evaluator_training import load_or_train_evaluator

    load_or_train_evaluator(_dataset(profile, seed, data), profile)


def make_discord(profile: str, seed: int, tokens: str, projection: str = "stacked", data: str | None = None,
                 overrides: dict | None = None, ablation: bool = False) -> None:  # fmt: skip
    from .flow import train_or_load_discord
    from .tokenizers import tokenizer_for_dataset

    dataset = _dataset(profile, seed, data)
    tokenizer = tokenizer_for_dataset(tokens, dataset, profile)
    config = projection_config(profile, tokenizer, projection, seed, ablation=ablation, **(overrides or {}))
    train_or_load_discord(dataset, tokenizer, profile, config=config)


# Chapter 04's ablation budget, as a fraction of the profile's DisCoRD training steps (and warm-up).
ABLATION_BUDGET = {"smoke": 0.5, "laptop": 0.25, "full": 1.0}


def projection_config(profile: str, tokenizer, projection: str = "stacked", seed: int = 0, *,
                      ablation: bool = False, **overrides):  # fmt: skip
    """The DisCoRD config of a condition projection: chapter 05's decoder with only the projection changed.

    ``ablation=True`` is chapter 04's setting: the same decoder at :data:`ABLATION_BUDGET` of its training steps.
    ``stacked`` (the paper's projection) without ``ablation`` *is* chapter 05's decoder.
    """
    from .flow import discord_config

    config = discord_config(profile, tokenizer=tokenizer, projection=projection, seed=seed, **overrides)
    if not ablation:
        return config
    fraction = ABLATION_BUDGET[get_profile(profile)]
    steps = max(1, round(config.train_steps * fraction))
    return replace(config, train_steps=steps, warmup_steps=min(steps - 1, round(config.warmup_steps * fraction)))


def make_text_to_motion(profile: str, seed: int, eta: float | None, training_seed: int | None = None,
                        data: str | None = None, distance: str = "l2_rank") -> None:  # fmt: skip
    from .diffusion import text_to_motion_for_dataset

    text_to_motion_for_dataset(_dataset(profile, seed, data), profile, eta=eta, seed=training_seed, distance=distance)


# -- the plan ------------------------------------------------------------------------------------------------------
def is_cached(run) -> bool:
    """Whether ``run()`` would only load: it runs under :func:`~motionlab.train.cache.cache_probe`."""
    with cache_probe():
        try:
            run()
        except NotCached:
            return False
    return True


def book_jobs(profile: str | None = None, seed: int = 0, *, data: str | None = None,
              flow_options: dict | None = None) -> list[Job]:
    """The book's models for ``profile``, in a valid training order (inputs first).

    ``data`` trains them on a dataset folder instead of the embedded data; ``flow_options`` override the
    config of the two ``stacked`` DisCoRD decoders (what ``train discord --predict ...`` does).
    """
    profile = get_profile(profile)
    cost = ESTIMATES_S[profile]
    on = {"data": data}

    def job(name: str, recipe, args: tuple, kind: str, after: tuple[str, ...] = (), **kwargs) -> Job:
        run = partial(recipe, profile, seed, *args, **on, **kwargs)
        return Job(name, run, after, cost[kind], partial(is_cached, run))

    vq, rvq, flow = ("tokenizer/vq",), ("tokenizer/rvq",), {"overrides": flow_options}
    return [
        job("data", make_data, (), "data"),
        # longest chains first, so the greedy scheduler starts them early
        job("tokenizer/rvq", make_tokenizer, ("rvq",), "tokenizer", ("data",)),
        job("tokenizer/vq", make_tokenizer, ("vq",), "tokenizer", ("data",)),
        job("discord/rvq", make_discord, ("rvq",), "discord", rvq, **flow),
        job("discord/vq", make_discord, ("vq",), "discord", vq, **flow),
        job("t2m/dynamic", make_text_to_motion, (None,), "t2m", vq),
        job("t2m/uniform", make_text_to_motion, (0.0,), "t2m", vq),
        job("t2m/multi-eta0.25", make_text_to_motion, (MULTI_MOTION_ETA,), "t2m", vq),
        # chapter 08's training-seed replicates (seed 0 of each arm is the pair above)
        job("t2m/dynamic-seed1", make_text_to_motion, (PAPER_ETA, 1), "t2m", vq),
        job("t2m/uniform-seed1", make_text_to_motion, (0.0, 1), "t2m", vq),
        *[job(f"ablation/{kind}", make_discord, ("rvq", kind), "ablation", rvq, ablation=True)
          for kind in ("stacked", "repeat", "transposed") if not (kind == "stacked" and ABLATION_BUDGET[profile] == 1)],
        *([job(f"t2m/distance-{d}", make_text_to_motion, (None, None), "t2m", vq, distance=d)
           for d in ("l2", "cosine", "cosine_rank")] if profile == "full" else []),  # chapter 08's distance ablation
        job("evaluator", make_evaluator, (), "evaluator", ("data",)),
        job("toy_flow/ring", make_toy_flow, (False,), "toy_flow"),
        job("toy_flow/ring-conditional", make_toy_flow, (True,), "toy_flow"),
    ]


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


__all__ = ["ABLATION_BUDGET", "ESTIMATES_S", "book_jobs", "is_cached", "jobs_for", "projection_config"]
