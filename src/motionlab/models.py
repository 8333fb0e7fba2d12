"""The book's models by name: one verb, :func:`load`, for every model a chapter or a command uses.

The names are those of the training plan (``motionlab train book`` prints them), so a chapter's model and the one the
plan trained share one cache entry by construction::

    from motionlab import models
    tokenizer = models.load("tokenizer/rvq", dataset)        # a Tokenizer (encode / decode)
    decoder = models.load("discord/rvq", dataset)            # a DisCoRDDecoder on the RVQ tokenizer's ids
    pipe = models.load("t2m/multi-eta0.25", dataset)         # a TextToMotion pipeline
    evaluator = models.load("evaluator", dataset)            # the text-motion evaluator (embed_motions, ...)

==============================  ==================================================================================
name                            model
==============================  ==================================================================================
``tokenizer/vq``, ``/rvq``      the motion VQ-VAE and the residual VQ-VAE (chapter 02)
``tokenizer/<kind>-seed<k>``    that tokenizer trained with seed ``k`` (the training-seed study; seed 0 is the book's)
``toy_flow/ring[-conditional]`` chapter 03's 2-D velocity field (``dataset`` is not used)
``discord/rvq``, ``/vq``        the profile's DisCoRD decoder on that tokenizer's ids (chapters 05, 09; the VQ one
                                trains a smaller, narrower laptop decoder, ``sizes.DISCORD_VQ``)
``discord/rvq-<projection>``    chapter 04's ablation decoders: ``stacked``, ``repeat``, ``transposed``
``discord/rvq-xpred``           the laptop's x-predicting variant of ``discord/rvq``: it predicts the clean motion
                                and decodes from zero start noise (``sizes.DISCORD_XPRED``; a lever, not the paper)
``discord/<kind>-seed<k>``      the decoder trained with seed ``k`` on ``tokenizer/<kind>-seed<k>``: a replicate of
                                the whole chain (the training-seed study, ``experiments/training_seeds.py``)
``t2m/dynamic``, ``/uniform``   the text-to-motion models with dynamic (paper η) and uniform (η = 0) transitions
``t2m/multi-eta0.25``           the dynamic model at M2D2M's multi-motion η (``-seed<k>``: a training-seed replicate)
``t2m/<arm>-seed<k>``           a training-seed replicate of ``dynamic`` or ``uniform`` (chapter 08)
``t2m/<arm>-steps<n>``          that model trained for ``n`` steps (also ``-seed<k>-steps<n>``; the budget study)
``t2m/eta<η>``                  the dynamic model at another η (the η sweeps of chapter 08 and experiments/)
``t2m/distance-<kind>``         chapter 08's distance ablation (``l2``, ``cosine``, ``cosine_rank``; full profile)
``evaluator``                   the text-motion evaluator of the FID / R-precision protocol
==============================  ==================================================================================

Each is trained on first use and cached (``$MOTIONLAB_HOME/models``); inside ``motionlab book execute`` a model that
is not cached is an error instead (the chapters only load).
"""

from __future__ import annotations

import re
from functools import lru_cache
from typing import Any

from motionlab.profiles import get_profile

PROJECTIONS = ("stacked", "repeat", "transposed")
DISTANCES = ("l2", "cosine", "cosine_rank")
_T2M = re.compile(r"^t2m/(dynamic|uniform)(?:-seed(\d+))?(?:-steps(\d+))?$")
_ETA = re.compile(r"^t2m/eta(\d+(?:\.\d+)?)$")  # the dynamic model at any η (training seed 0): η sweeps
_MULTI = re.compile(r"^t2m/multi-eta0\.25(?:-seed(\d+))?$")
_SEEDED = re.compile(r"^(vq|rvq)(?:-seed(\d+))?$")  # a tokenizer kind, or a replicate of its training chain
# One table for what the book's models train: by name prefix, the network motionlab.train.compiling may compile (one of
# its PARTS) and the model of the GPU benchmark (benchmarks/bench_gpu.py, book/data/gpu/) that timed that training and
# its compiling. The benchmark timed the RVQ tokenizer only: the VQ one borrows no time from it. The other models
# (data, evaluator, toy flows) never compile and were never timed.
NETWORKS: dict[str, tuple[str, str | None]] = {  # name prefix -> (compiled part, benchmark model)
    "tokenizer/vq": ("tokenizer", None),
    "tokenizer/rvq": ("tokenizer", "rvq"),
    "discord/": ("discord", "discord"),
    "t2m/": ("denoiser", "t2m"),
}


def _network(name: str) -> tuple[str, str | None] | None:
    return next((entry for prefix, entry in NETWORKS.items() if name.startswith(prefix)), None)


def compiled_part(name: str) -> str | None:
    """The part (:data:`motionlab.train.compiling.PARTS`) that compiling targets when the book's model ``name``
    trains, e.g. ``"denoiser"`` for ``t2m/dynamic``; None for the models that never compile (data, evaluator, toy
    flows)."""
    entry = _network(name)
    return entry[0] if entry else None


def benchmark_model(name: str) -> str | None:
    """The GPU benchmark's model whose training step and compile stand for the book's model ``name`` (e.g. ``"t2m"``
    for ``t2m/dynamic``); None where the benchmark timed none (the VQ tokenizer, the evaluator, ...)."""
    entry = _network(name)
    return entry[1] if entry else None


def _tokenizer(kind: str, dataset, profile: str, device, seed: int = 0):
    from motionlab.tokenizers import tokenizer_for_dataset

    return tokenizer_for_dataset(kind, dataset, profile, seed=seed, device=device)


def _discord(variant: str, dataset, profile: str, seed: int, device, overrides: dict[str, Any]):
    from motionlab.flow import discord_config, train_or_load_discord
    from motionlab.sizes import DISCORD_VQ

    chain = _SEEDED.match(variant)
    tokens, _, projection = variant.partition("-")
    if chain is None and (tokens != "rvq" or projection not in (*PROJECTIONS, "xpred")):
        raise ValueError(
            f"unknown DisCoRD decoder 'discord/{variant}'; use discord/rvq, discord/vq, discord/<kind>-seed<k>, "
            f"discord/rvq-xpred or discord/rvq-{{{','.join(PROJECTIONS)}}}"
        )
    chain_seed = int(chain.group(2) or 0) if chain else 0
    if chain_seed and seed:
        raise ValueError(f"'discord/{variant}' names its training seed; do not pass seed={seed} as well")
    if chain:
        tokens, projection, seed = chain.group(1), "", chain_seed or seed
    tokenizer = _tokenizer(tokens, dataset, profile, device, chain_seed)
    if projection == "xpred":
        config = xpred_config(profile, tokenizer, seed, **overrides)
    elif projection:
        config = projection_config(profile, tokenizer, projection, seed, **overrides)
    else:  # the VQ tokens' decoder has its own, smaller laptop decoder (sizes.DISCORD_VQ says why)
        budget = DISCORD_VQ.get(profile, {}) if tokens == "vq" else {}
        config = discord_config(profile, tokenizer=tokenizer, seed=seed, **{**budget, **overrides})
    return train_or_load_discord(dataset, tokenizer, profile, config=config, device=device)


def _text_to_motion(variant: str, dataset, profile: str, device):
    from motionlab.diffusion import text_to_motion_for_dataset
    from motionlab.diffusion.training import PAPER_ETA, budget_config
    from motionlab.multimotion import MULTI_MOTION_ETA

    name = f"t2m/{variant}"
    if (multi := _MULTI.match(name)) is not None:  # seed 0 (or none): the book's multi-motion model
        seed = int(multi.group(1) or 0)
        return text_to_motion_for_dataset(dataset, profile, eta=MULTI_MOTION_ETA, seed=seed or None, device=device)
    if (eta := _ETA.match(name)) is not None:
        return text_to_motion_for_dataset(dataset, profile, eta=float(eta.group(1)), device=device)
    if variant.startswith("distance-") and variant[len("distance-") :] in DISTANCES:
        return text_to_motion_for_dataset(dataset, profile, distance=variant[len("distance-") :], device=device)
    match = _T2M.match(name)
    if not match:
        raise ValueError(
            f"unknown text-to-motion model {name!r}; use t2m/dynamic, t2m/uniform, t2m/<arm>-seed<k>, "
            f"t2m/multi-eta0.25[-seed<k>], t2m/eta<η> or t2m/distance-{{{','.join(DISTANCES)}}}"
        )
    arm, training_seed, steps = match.group(1), match.group(2), match.group(3)
    if steps is not None:  # another training budget: the profile's model trained for `steps` steps
        return text_to_motion_for_dataset(
            dataset,
            profile,
            config=budget_config(
                profile,
                num_codes=_tokenizer("vq", dataset, profile, device).codebook_size,
                dynamic=arm == "dynamic",
                steps=int(steps),
            ),
            seed=int(training_seed or 0),
            device=device,
        )
    if training_seed is None:  # seed 0 of each arm: the profile's default eta and seed
        return text_to_motion_for_dataset(dataset, profile, eta=None if arm == "dynamic" else 0.0, device=device)
    eta = PAPER_ETA if arm == "dynamic" else 0.0
    return text_to_motion_for_dataset(dataset, profile, eta=eta, seed=int(training_seed), device=device)


def load(
    name: str,
    dataset=None,
    profile: str | None = None,
    *,
    seed: int = 0,
    device: str | None = None,
    **overrides: Any,
):
    """The book's model ``name`` for ``dataset`` (default: the profile's embedded dataset) and ``profile``.

    Returns the object a chapter uses: a tokenizer, a DisCoRD decoder, a text-to-motion pipeline, the evaluator, or
    the toy velocity field. ``overrides`` change a DisCoRD decoder's config (e.g. ``prediction="x"``; a different
    config is a different cached model). ``seed`` is the data seed of the default dataset and the DisCoRD
    decoder's training seed, as in the training plan.
    """
    profile = get_profile(profile)
    if not isinstance(name, str) or "/" not in name and name not in ("evaluator", "data"):
        raise ValueError(f"model names look like 'discord/rvq' or 'evaluator', got {name!r}")
    kind, _, variant = name.partition("/")
    if overrides and kind != "discord":
        raise ValueError(f"only DisCoRD decoders take config overrides, not {name!r}: got {sorted(overrides)}")
    if kind == "toy_flow":
        from motionlab.flow.toy import toy_flow_config, train_or_load_toy_flow

        if variant not in ("ring", "ring-conditional"):
            raise ValueError(f"unknown toy flow {name!r}; use toy_flow/ring or toy_flow/ring-conditional")
        config = toy_flow_config(profile, distribution="ring", conditional=variant.endswith("conditional"), seed=seed)
        return train_or_load_toy_flow(config, profile=profile)
    if dataset is None:
        dataset = book_dataset(profile, seed)
    if kind == "data":
        return dataset
    if kind == "tokenizer":
        if (chain := _SEEDED.match(variant)) is None:
            raise ValueError(f"unknown tokenizer {name!r}; use tokenizer/vq, tokenizer/rvq or tokenizer/<kind>-seed<k>")
        return _tokenizer(chain.group(1), dataset, profile, device, int(chain.group(2) or 0))
    if kind == "discord":
        return _discord(variant, dataset, profile, seed, device, overrides)
    if kind == "t2m":
        return _text_to_motion(variant, dataset, profile, device)
    if kind == "evaluator":
        from motionlab.metrics.evaluator_training import load_or_train_evaluator

        return load_or_train_evaluator(dataset, profile, device=device)
    raise ValueError(f"unknown model {name!r}; the names are listed in motionlab.models' docstring")


# -- the data and configs the book's models are trained on ----------------------------------------------------
@lru_cache(maxsize=4)
def _dataset(profile: str, seed: int, data: str | None, home: str):
    # ``home`` (the cache root) is only part of the key: the embedded dataset lives there
    from motionlab.data import load_dataset

    return load_dataset(data, profile=profile, seed=seed)


def book_dataset(profile: str, seed: int = 0, data: str | None = None):
    """The dataset the recipes train on, loaded once per process for each profile, seed, folder and cache root.

    The plan's cache checks run every recipe, so they share one loaded dataset; a command that checks its plan
    first and then does its work (``motionlab evaluate``, ``generate``, ``train``) uses that same instance.
    :func:`forget_book_datasets` drops them (e.g. when the dataset's folder was rewritten meanwhile).
    """
    from motionlab.paths import cache_dir

    return _dataset(profile, seed, data, str(cache_dir()))


def forget_book_datasets() -> None:
    """Drop the datasets :func:`book_dataset` holds: the next call reads its folder again."""
    _dataset.cache_clear()


# Training steps of chapter 04's projection ablation, where they differ from the profile's DisCoRD decoder.
def projection_config(profile: str, tokenizer, projection: str = "stacked", seed: int = 0, **overrides):
    """The DisCoRD config of chapter 04's ablation: chapter 05's decoder with the projection changed and, in the
    laptop profile, the smaller ablation budget (``DISCORD_ABLATION`` in :mod:`motionlab.sizes`)."""
    from motionlab.flow import discord_config
    from motionlab.sizes import DISCORD_ABLATION

    budget = DISCORD_ABLATION.get(get_profile(profile), {})
    return discord_config(profile, tokenizer=tokenizer, projection=projection, seed=seed, **{**budget, **overrides})


def xpred_config(profile: str, tokenizer, seed: int = 0, **overrides):
    """The DisCoRD config of ``discord/rvq-xpred``: chapter 05's decoder with the laptop's levers pulled (it predicts
    the clean motion and decodes from zero start noise; ``DISCORD_XPRED`` in :mod:`motionlab.sizes` says why)."""
    from motionlab.flow import discord_config
    from motionlab.sizes import DISCORD_XPRED, XPRED_LEVERS

    levers = DISCORD_XPRED.get(get_profile(profile), XPRED_LEVERS)
    return discord_config(profile, tokenizer=tokenizer, seed=seed, **{**levers, **overrides})


__all__ = [
    "NETWORKS",
    "benchmark_model",
    "book_dataset",
    "compiled_part",
    "forget_book_datasets",
    "load",
    "projection_config",
    "xpred_config",
]
