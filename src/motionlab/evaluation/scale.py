"""The scale study's points: which models a point trains, how a multiple of the laptop budget changes their configs,
and the configs a point's record carries (so that the book can set aside a record the code no longer reproduces).

A *point* is one model group trained at one *multiple* of its profile's training budget, counted in training samples
(steps × batch), at the profile's widths, and scored with the chapters' own evaluations:

=============  =====================================================================================================
group          models (all trained at the multiple) and evaluation
=============  =====================================================================================================
``discord``    ``tokenizer/rvq`` and ``discord/rvq`` on its tokens: chapter 05's reconstruction table (no timing)
``projection`` ``tokenizer/rvq`` and chapter 04's ``discord/rvq-{stacked,repeat,transposed}``: its ablation table
``m2d2m``      ``tokenizer/vq`` and ``t2m/{multi-eta0.25,uniform,dynamic}`` on its tokens: chapter 09's multi-motion
               tables, chapter 07's guidance rows and chapter 08's dynamic-vs-uniform table
=============  =====================================================================================================

The text-motion evaluator is the profile's in every point (one evaluator for all, so FIDs compare across multiples).

How a multiple ``m`` with batch factor ``b`` (a power of two that divides the work into larger batches) changes a
model's training: the batch becomes ``b ×`` the profile's, the steps ``m / b ×`` (so the samples are ``m ×``), the
decay of the learning rate is stretched over the run as it is in the profile (cosine, or the drop at 100/110), and
the warm-up keeps the profile's number of *samples* (``1 / b ×`` its steps), as the budget study keeps its steps.
The learning rate itself is the profile's: no scaling rule is applied for the larger batch.

:func:`scaled_budgets` applies this to the size tables of :mod:`motionlab.sizes` for the duration of a ``with``
block, so that every config function, and hence every cache key, sees the scaled budget: the evaluations load their
models by the book's names and get the scaled ones, trained on first use into their own cache entries.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from typing import Any

from motionlab import sizes
from motionlab.profiles import get_profile

GROUPS = ("discord", "projection", "m2d2m")
MULTIPLES = (10, 30, 100, 300, 1000, 3000)  # the GPU runs' ladder, smallest first
# Size tables a multiple scales, with the paths of (steps, warm-up steps, batch size) in a profile's entry; None where
# the table holds no such field (the denoiser's warm-up lives in DIFFUSION_TRAINING). The evaluator, the toy flow and
# the word encoder's widths are not scaled.
_BUDGET_FIELDS: dict[str, tuple[tuple[str, ...] | None, ...]] = {
    "TOKENIZER": (("train", "steps"), ("train", "warmup_steps"), ("batch_size",)),
    "RVQ_TOKENIZER": (("train", "steps"), ("train", "warmup_steps"), ("batch_size",)),
    "DISCORD_DECODER": (("train_steps",), ("warmup_steps",), ("batch_size",)),
    "DISCORD_ABLATION": (("train_steps",), ("warmup_steps",), ("batch_size",)),
    "DISCORD_VQ": (("train_steps",), ("warmup_steps",), ("batch_size",)),
    "DENOISER": (("train_steps",), None, ("batch_size",)),
    "DIFFUSION_TRAINING": (None, ("warmup_steps",), None),
}
PROJECTIONS = {"stacked": "stacked", "repeat": "repeat_linear", "transposed": "transposed"}  # model -> claim key


def check_point(multiple: float, batch_factor: int) -> None:
    """A multiple is a positive number (fractions only make sense for the smoke pipeline); ``batch_factor`` a power
    of two no larger than the multiple rounds to (a point never trains fewer steps than one)."""
    if isinstance(multiple, bool) or not isinstance(multiple, (int, float)) or not math.isfinite(multiple):
        raise ValueError(f"a multiple must be a finite number, got {multiple!r}")
    if multiple <= 0:
        raise ValueError(f"a multiple must be > 0, got {multiple!r}")
    if isinstance(batch_factor, bool) or not isinstance(batch_factor, int) or batch_factor < 1:
        raise ValueError(f"batch_factor must be an int >= 1, got {batch_factor!r}")
    if batch_factor & (batch_factor - 1):
        raise ValueError(f"batch_factor must be a power of two, got {batch_factor}")


def _scaled_entry(entry: dict, paths: tuple, multiple: float, batch_factor: int) -> dict:
    """A copy of one profile's size-table entry with its budget scaled (nested dicts copied, never changed)."""
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in entry.items()}
    steps, warmup, batch = paths

    def update(path, change) -> None:
        if path is None:
            return
        *parents, leaf = path
        node = out
        for name in parents:
            node = node.get(name)
            if node is None:
                return
        if leaf in node:
            node[leaf] = change(node[leaf])

    update(steps, lambda n: max(1, round(n * multiple / batch_factor)))
    update(warmup, lambda n: max(1, round(n / batch_factor)) if n else n)
    update(batch, lambda n: n * batch_factor)
    return out


@contextlib.contextmanager
def scaled_budgets(multiple: float, batch_factor: int = 1, profile: str | None = None) -> Iterator[None]:
    """Inside the block, ``profile``'s models train on ``multiple ×`` its samples (module docstring); restored after.

    Only profiles whose size tables set the budgets (``smoke``, ``laptop``) can be scaled: ``full`` is the papers'.
    Not thread-safe: it changes module-level tables, as a build changes them for the whole process.
    """
    profile = get_profile(profile)
    check_point(multiple, batch_factor)
    if "train_steps" not in sizes.DENOISER.get(profile, {}):
        raise ValueError(f"the scale study multiplies a profile's own budget, and {profile!r} sets none")
    saved = {name: getattr(sizes, name)[profile] for name in _BUDGET_FIELDS if profile in getattr(sizes, name)}
    try:
        for name, entry in saved.items():
            getattr(sizes, name)[profile] = _scaled_entry(entry, _BUDGET_FIELDS[name], multiple, batch_factor)
        yield
    finally:
        for name, entry in saved.items():  # the original objects, so that tables sharing an entry share it again
            getattr(sizes, name)[profile] = entry


def group_models(group: str) -> tuple[str, ...]:
    """The :func:`motionlab.models.load` names a point of ``group`` trains (the evaluator: the profile's)."""
    if group == "discord":
        return ("tokenizer/rvq", "discord/rvq")
    if group == "projection":
        return ("tokenizer/rvq", *(f"discord/rvq-{p}" for p in PROJECTIONS))
    if group == "m2d2m":
        return ("tokenizer/vq", "t2m/multi-eta0.25", "t2m/uniform", "t2m/dynamic")
    raise ValueError(f"group must be one of {GROUPS}, got {group!r}")


def group_evaluations(group: str, profile: str | None = None) -> dict[str, Any]:
    """The evaluations that score a point of ``group``, by role: the training-seed study's configs at seed 0 (the
    chapters' sizes), plus chapter 08's table for ``m2d2m`` and chapter 04's ablation sizes for ``projection``."""
    from .studies import study_plan

    profile = get_profile(profile)
    if group == "discord":
        return dict(study_plan("discord", 0, profile).evaluations)
    if group == "m2d2m":
        return {**study_plan("m2d2m", 0, profile).evaluations, **study_plan("transitions", 0, profile).evaluations}
    if group == "projection":
        ablation = sizes.chapter_sizes(profile).projection
        return {"projection": {"windows": ablation.windows, "clips": ablation.clips, "seed": 0}}
    raise ValueError(f"group must be one of {GROUPS}, got {group!r}")


def _model_configs(group: str, profile: str) -> dict[str, Any]:
    """The training configs of ``group``'s models and of the evaluator, as the current size tables build them."""
    from types import SimpleNamespace

    from motionlab.metrics.evaluator_training import evaluator_config
    from motionlab.models import projection_config
    from motionlab.tokenizers import rvq_config

    from .studies import _model_configs as study_model_configs

    if group == "discord":
        return study_model_configs("discord", profile)
    if group == "m2d2m":
        return study_model_configs("m2d2m", profile)
    from motionlab.tokenizers.models import RVQVAE

    tokenizer = rvq_config(profile)
    # what projection_config reads of a tokenizer, without building the network
    shape = SimpleNamespace(
        feature_dim=tokenizer.feature_dim, code_dim=tokenizer.code_dim, downsample=RVQVAE.downsample
    )
    configs: dict[str, Any] = {"tokenizer/rvq": tokenizer, "evaluator": evaluator_config(profile)}
    for projection in PROJECTIONS:
        configs[f"discord/rvq-{projection}"] = projection_config(profile, shape, projection)
    return configs


def point_configs(group: str, multiple: float, batch_factor: int = 1, profile: str | None = None) -> dict[str, Any]:
    """What a point's numbers depend on besides the machine: ``{"models": {name: config}, "evaluations": {role:
    config}}``, every field resolved, as JSON-ready dicts. Builds configs only: no data, no training."""
    from motionlab.train.cache import config_dict

    profile = get_profile(profile)
    evaluations = group_evaluations(group, profile)
    with scaled_budgets(multiple, batch_factor, profile):
        models = {name: config_dict(config) for name, config in _model_configs(group, profile).items()}
    return {
        "models": models,
        "evaluations": {role: c if isinstance(c, dict) else config_dict(c) for role, c in evaluations.items()},
    }


def training_steps(config: Any) -> tuple[int, int]:
    """``(steps, batch size)`` of a tokenizer, DisCoRD or text-to-motion training config (or its JSON dict)."""
    get = (lambda c, k: c[k]) if isinstance(config, dict) else getattr
    if _has(config, "transformer"):
        t = get(config, "transformer")
        return int(get(t, "train_steps")), int(get(t, "batch_size"))
    if _has(config, "train_steps"):
        return int(get(config, "train_steps")), int(get(config, "batch_size"))
    return int(get(get(config, "train"), "steps")), int(get(config, "batch_size"))


def _has(config: Any, name: str) -> bool:
    return name in config if isinstance(config, dict) else hasattr(config, name)


def point_changes(record: dict[str, Any], profile: str | None = None) -> list[str] | None:
    """Where a point's record was measured with other configs than the code builds now (dotted paths); None where
    it holds no configs to compare (then it is set aside too)."""
    from .studies import config_changes

    recorded = record.get("configs")
    if not isinstance(recorded, dict) or "models" not in recorded:
        return None
    current = point_configs(record["group"], record["multiple"], int(record.get("batch_factor", 1)), profile)
    return config_changes(recorded, current)
