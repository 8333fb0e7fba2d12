"""Every model the book's chapters load, as one plan: what to train, in which order, how long it takes.

``motionlab train book`` runs this plan (see :mod:`motionlab.train.plan`) before the chapters execute, so a
chapter only loads from the cache. Each recipe below makes the *same call* a chapter makes (same function,
same profile, same config), so the cache keys agree by construction; a test checks that the chapters find
everything cached after the plan ran.

    data ─┬─ tokenizer/vq ──┬─ t2m/dynamic, t2m/uniform           (chapters 07, 08, 09)
          │                 ├─ t2m/multi-eta0.25                   (chapters 08, 09)
          │                 ├─ t2m/dynamic-seed1, t2m/uniform-seed1 (chapter 08's training-seed control)
          │                 └─ discord/vq                          (chapter 09)
          ├─ tokenizer/rvq ─── discord/rvq, discord/rvq-repeat,
          │                    discord/rvq-transposed              (chapters 04, 05)
          └─ evaluator                                             (chapters 05–09)
    toy_flow/ring, toy_flow/ring-conditional                       (chapter 03)

``discord/rvq`` is chapter 05's decoder and chapter 04's ``stacked`` row: one flow decoder per token type,
shared by the chapters that need it.
"""

from __future__ import annotations

from functools import lru_cache, partial

from .diffusion.training import PAPER_ETA
from .multimotion import MULTI_MOTION_ETA
from .profiles import get_profile
from .train.cache import NotCached, cache_probe
from .train.plan import Job

# Training seconds per model on one core of the reference machine (2 cores, two 1-thread workers), measured
# by `motionlab train book`; they drive the plan line and the progress estimates, nothing else.
ESTIMATES_S: dict[str, dict[str, float]] = {
    "smoke": {"data": 8, "tokenizer": 10, "toy_flow": 5, "evaluator": 10, "discord": 10, "t2m": 15},
    "laptop": {"data": 150, "tokenizer": 330, "toy_flow": 60, "evaluator": 300, "discord": 590, "t2m": 780},
    "full": {"data": 1500, "tokenizer": 36_000, "toy_flow": 300, "evaluator": 36_000, "discord": 360_000,
             "t2m": 180_000},
}  # fmt: skip


# -- recipes: module-level so worker processes can unpickle them --------------------------------------------------
@lru_cache(maxsize=4)  # the plan's cache checks share one loaded dataset
def _dataset(profile: str, seed: int):
    from .data import load_dataset

    return load_dataset(profile=profile, seed=seed)


def make_data(profile: str, seed: int) -> None:
    _dataset(profile, seed)


def make_tokenizer(profile: str, seed: int, kind: str) -> None:
    from .tokenizers import tokenizer_for_dataset

    tokenizer_for_dataset(kind, _dataset(profile, seed), profile)


def make_toy_flow(profile: str, seed: int, conditional: bool) -> None:
    from .flow.toy import toy_flow_config, train_or_load_toy_flow

    train_or_load_toy_flow(toy_flow_config(profile, distribution="ring", conditional=conditional, seed=seed),
                           profile=profile)  # fmt: skip


def make_evaluator(profile: str, seed: int) -> None:
    from .metrics.evaluator_training import load_or_train_evaluator

    load_or_train_evaluator(_dataset(profile, seed), profile)


def make_discord(profile: str, seed: int, tokens: str, projection: str = "stacked") -> None:
    from .flow import train_or_load_discord
    from .tokenizers import tokenizer_for_dataset

    dataset = _dataset(profile, seed)
    tokenizer = tokenizer_for_dataset(tokens, dataset, profile)
    train_or_load_discord(dataset, tokenizer, profile, config=projection_config(profile, tokenizer, projection, seed))


def projection_config(profile: str, tokenizer, projection: str = "stacked", seed: int = 0):
    """The DisCoRD config of a condition projection: chapter 05's decoder with only the projection changed.

    ``stacked`` (the paper's) *is* chapter 05's decoder, so chapter 04's ablation shares it.
    """
    from .flow import discord_config

    return discord_config(profile, tokenizer=tokenizer, projection=projection, seed=seed)


def make_text_to_motion(profile: str, seed: int, eta: float | None, training_seed: int | None = None) -> None:
    from .diffusion import text_to_motion_for_dataset

    text_to_motion_for_dataset(_dataset(profile, seed), profile, eta=eta, seed=training_seed)


# -- the plan ------------------------------------------------------------------------------------------------------
def is_cached(run) -> bool:
    """Whether ``run()`` would only load: it runs under :func:`~motionlab.train.cache.cache_probe`."""
    with cache_probe():
        try:
            run()
        except NotCached:
            return False
    return True


def book_jobs(profile: str | None = None, seed: int = 0) -> list[Job]:
    """The book's models for ``profile``, in a valid training order (inputs first)."""
    profile = get_profile(profile)
    cost = ESTIMATES_S[profile]

    def job(name: str, run, kind: str, after: tuple[str, ...] = ()) -> Job:
        return Job(name, run, after, cost[kind], partial(is_cached, run))

    return [
        job("data", partial(make_data, profile, seed), "data"),
        # longest chains first, so the greedy scheduler starts them early
        job("tokenizer/rvq", partial(make_tokenizer, profile, seed, "rvq"), "tokenizer", ("data",)),
        job("tokenizer/vq", partial(make_tokenizer, profile, seed, "vq"), "tokenizer", ("data",)),
        job("discord/rvq", partial(make_discord, profile, seed, "rvq"), "discord", ("tokenizer/rvq",)),
        job("discord/vq", partial(make_discord, profile, seed, "vq"), "discord", ("tokenizer/vq",)),
        job("t2m/dynamic", partial(make_text_to_motion, profile, seed, None), "t2m", ("tokenizer/vq",)),
        job("t2m/uniform", partial(make_text_to_motion, profile, seed, 0.0), "t2m", ("tokenizer/vq",)),
        job("t2m/multi-eta0.25", partial(make_text_to_motion, profile, seed, MULTI_MOTION_ETA), "t2m",
            ("tokenizer/vq",)),
        # chapter 08's training-seed replicates (seed 0 of each arm is the pair above)
        job("t2m/dynamic-seed1", partial(make_text_to_motion, profile, seed, PAPER_ETA, 1), "t2m", ("tokenizer/vq",)),
        job("t2m/uniform-seed1", partial(make_text_to_motion, profile, seed, 0.0, 1), "t2m", ("tokenizer/vq",)),
        job("discord/rvq-repeat", partial(make_discord, profile, seed, "rvq", "repeat"), "discord", ("tokenizer/rvq",)),
        job("discord/rvq-transposed", partial(make_discord, profile, seed, "rvq", "transposed"), "discord",
            ("tokenizer/rvq",)),
        job("evaluator", partial(make_evaluator, profile, seed), "evaluator", ("data",)),
        job("toy_flow/ring", partial(make_toy_flow, profile, seed, False), "toy_flow"),
        job("toy_flow/ring-conditional", partial(make_toy_flow, profile, seed, True), "toy_flow"),
    ]  # fmt: skip


__all__ = ["ESTIMATES_S", "book_jobs", "is_cached", "projection_config"]
