"""The recorded studies: the models each trains, the evaluations that score them, and the configs behind both.

A training-seed study (``experiments/training_seeds.py``) trains a chapter's models with other seeds and scores every
run with the chapter's own evaluation; :mod:`motionlab.report.spread` pools the recorded runs with this build's.
Pooling is only right while the recorded runs are of the models and evaluations the book has now: a run recorded
before a model's training steps or width, or an evaluation's sizes, changed measured something else. So every study
file records :func:`study_configs`, the resolved configs of the models it trained and of the evaluations that scored
them (at seed 0, since the seeds differ only in their seed), and :func:`motionlab.report.spread.read_spread` sets
aside a run whose configs are not the code's.

==============  =====================================================================================================
study           models (seed k > 0 adds ``-seed<k>``) and their evaluation
==============  =====================================================================================================
``discord``     ``tokenizer/rvq`` and ``discord/rvq``, scored by chapter 05's reconstruction table (without timing)
``m2d2m``       ``t2m/multi-eta0.25`` (chapter 09's multi-motion table), ``t2m/uniform`` (its TPS rows) and
                ``t2m/dynamic`` (chapter 07's guidance rows, s = 0 and 4), on the book's VQ tokens and evaluator
``transitions`` ``t2m/uniform`` and ``t2m/dynamic`` scored by chapter 08's table (single motions at s = 4)
==============  =====================================================================================================

The budget study and the η axis (``experiments/m2d2m_budget.py``) are checked the same way: :func:`budget_changes`;
the scale study (``experiments/scale.py``) too, with :func:`motionlab.evaluation.scale.point_changes`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import Any

from motionlab.profiles import get_profile

STUDIES = ("discord", "m2d2m", "transitions")


@dataclass(frozen=True)
class StudyPlan:
    """One run of a study: the models it trains (by :func:`motionlab.models.load` name) and its evaluations' configs
    (:class:`~motionlab.evaluation.ReconstructionConfig`, :class:`~motionlab.evaluation.MultiMotionConfig` or
    :class:`~motionlab.evaluation.TextToMotionConfig`, by role)."""

    study: str
    training_seed: int
    models: tuple[str, ...]
    evaluations: dict[str, Any]


def study_plan(study: str, training_seed: int, profile: str | None = None) -> StudyPlan:
    """The models and evaluations of ``study``'s run at ``training_seed`` (0: the book's own models)."""
    from motionlab.evaluation.multi import paper_config
    from motionlab.evaluation.reconstruction import ReconstructionConfig
    from motionlab.evaluation.t2m import TextToMotionConfig, seed_replica
    from motionlab.sizes import chapter_sizes

    if study not in STUDIES:
        raise ValueError(f"study must be one of {STUDIES}, got {study!r}")
    if isinstance(training_seed, bool) or not isinstance(training_seed, int) or training_seed < 0:
        raise ValueError(f"training_seed must be an int >= 0, got {training_seed!r}")
    sizes = chapter_sizes(get_profile(profile))
    uniform, dynamic = seed_replica("uniform", training_seed), seed_replica("dynamic", training_seed)
    if study == "discord":
        config = ReconstructionConfig.from_sizes(sizes.discord, training_seed=training_seed)
        evaluation = replace(config, timing_repeats=0)  # the timing measures the machine, not the models
        return StudyPlan(study, training_seed, tuple(evaluation.book_models()), {"reconstruction": evaluation})
    if study == "transitions":
        config = TextToMotionConfig.from_sizes(sizes.transitions, models=(uniform, dynamic))
        return StudyPlan(study, training_seed, (uniform, dynamic), {"t2m": config})
    multi = "t2m/multi-eta0.25" + (f"-seed{training_seed}" if training_seed else "")
    evaluations = {
        "multi": paper_config(sizes.tps, model=multi),
        "multi_uniform": paper_config(sizes.tps, model=uniform, methods=("independent", "tps")),
        "guidance": TextToMotionConfig.from_sizes(
            sizes.diffusion,
            models=(dynamic,),
            guidance_scales=(0.0, 4.0),
            multimodality=False,
            reconstruction=False,
            token_stats=False,
        ),
    }
    return StudyPlan(study, training_seed, (multi, uniform, dynamic), evaluations)


def study_configs(study: str, profile: str | None = None) -> dict[str, dict[str, Any]]:
    """What ``study``'s numbers depend on besides the seed and the precision, as JSON-ready dicts:
    ``{"models": {name: config}, "evaluations": {role: config}}`` of its seed-0 run, every field resolved.

    Builds configs only: no data, no training, no network.
    """
    from motionlab.train.cache import config_dict

    profile = get_profile(profile)
    plan = study_plan(study, 0, profile)
    return {
        "models": {name: config_dict(config) for name, config in _model_configs(study, profile).items()},
        "evaluations": {role: config_dict(config) for role, config in plan.evaluations.items()},
    }


def _model_configs(study: str, profile: str) -> dict[str, Any]:
    """The seed-0 training configs of the models ``study`` trains and of those it reads (tokenizer, evaluator)."""
    from motionlab.metrics.evaluator_training import evaluator_config
    from motionlab.tokenizers import rvq_config, vq_config

    evaluator = evaluator_config(profile)  # every study's FID and R-precision
    if study == "discord":
        from motionlab.flow import discord_config
        from motionlab.tokenizers.models import RVQVAE

        tokenizer = rvq_config(profile)
        # what discord_config reads of a tokenizer, without building the network
        shape = SimpleNamespace(
            feature_dim=tokenizer.feature_dim, code_dim=tokenizer.code_dim, downsample=RVQVAE.downsample
        )
        return {
            "tokenizer/rvq": tokenizer,
            "discord/rvq": discord_config(profile, tokenizer=shape),
            "evaluator": evaluator,
        }
    from motionlab.diffusion.training import diffusion_training_config
    from motionlab.multimotion import MULTI_MOTION_ETA

    tokenizer = vq_config(profile)
    t2m = {"t2m/uniform": 0.0, "t2m/dynamic": None}  # None: the paper's η
    if study == "m2d2m":
        t2m = {"t2m/multi-eta0.25": MULTI_MOTION_ETA, **t2m}
    configs = {"tokenizer/vq": tokenizer, "evaluator": evaluator}
    for name, eta in t2m.items():
        configs[name] = diffusion_training_config(profile, num_codes=tokenizer.codebook_size, eta=eta)
    return configs


# ------------------------------------------------------------------------------------- the claim numbers of a study
# What the claims table reads of each study's tables (as Estimates: the training-seed study keeps their means, the
# scale study their intervals too).
def reconstruction_values(table, config) -> dict[str, Any]:
    """``{"discord/<key>": Estimate}``: chapter 05's claim cells of a reconstruction ``table`` (its ``config``)."""
    from .reconstruction import claim_cells

    return {f"discord/{key}": table.estimate(row, m) for key, (row, m) in claim_cells(table, config).items()}


def m2d2m_values(multi, multi_uniform, guidance_table, guidance) -> dict[str, Any]:
    """M2D2M's claim numbers of the ``m2d2m`` study's three tables: chapter 09's multi-motion cells (``tps/...``),
    TPS of the uniform model (``tps/jerk_tps_uniform``), and chapter 07's guidance rows of the dynamic model
    (``diffusion/fid_guided`` at s = 4, ``diffusion/fid_unguided`` at s = 0; ``guidance``: that table's config)."""
    from .multi import claim_cells

    values = {f"tps/{key}": multi.estimate(row, m) for key, (row, m) in claim_cells(multi).items()}
    values["tps/jerk_tps_uniform"] = multi_uniform.estimate(claim_cells(multi_uniform)["jerk_tps"][0], "jerk")
    dynamic = guidance.models[0]
    for key, scale in (("fid_guided", 4.0), ("fid_unguided", 0.0)):
        values[f"diffusion/{key}"] = guidance_table.estimate(guidance.row(dynamic, scale), "fid")
    return values


def transitions_values(table, config) -> dict[str, Any]:
    """Chapter 08's comparison in a ``transitions`` table (``config.models``: the uniform arm, then the dynamic one):
    ``transitions/{fid,top3}_{dynamic,uniform}``."""
    uniform, dynamic = config.models
    return {
        f"transitions/{metric}_{arm}": table.estimate(config.row(name), metric)
        for arm, name in (("dynamic", dynamic), ("uniform", uniform))
        for metric in ("fid", "top3")
    }


# Fields added to the evaluation configs after records were measured, with the value that does what every earlier
# run did: a record without the field measured that value, so it is not a change.
ADDED_FIELDS: dict[str, Any] = {"guidance_on": "x0"}


def config_changes(recorded: dict[str, Any], current: dict[str, Any], prefix: str = "") -> list[str]:
    """The dotted paths at which two nested config dicts differ (``"models.discord/rvq.train_steps"``), sorted.

    A field of :data:`ADDED_FIELDS` that the recorded config lacks reads as the value it had before it existed."""
    changes = []
    for key in sorted(set(recorded) | set(current)):
        path = f"{prefix}{key}"
        a, b = recorded.get(key, ADDED_FIELDS.get(key, _MISSING)), current.get(key, _MISSING)
        if isinstance(a, dict) and isinstance(b, dict):
            changes += config_changes(a, b, f"{path}.")
        elif a != b:
            changes.append(path)
    return changes


_MISSING = object()


def changes_phrase(changes: list[str], shown: int = 3) -> str:
    """``"its configs differ at a.b, c and 2 more"``: why a recorded run is set aside, for a reader."""
    more = f" and {len(changes) - shown} more" if len(changes) > shown else ""
    return f"its configs differ from the code's at {', '.join(changes[:shown])}{more}"


# ------------------------------------------------------------------------------------------- the guidance space
# ``experiments/guidance_space.py``: the book's seed-0 text-to-motion models scored with guidance on p_θ(x_0 | x_t)
# (VQ-Diffusion's code, the book's sampler) and on p_θ(x_{t-1} | x_t) (M2D2M's Eq. 9), at the chapters' sizes.
def guidance_evaluations(guidance_on: str, profile: str | None = None) -> dict[str, Any]:
    """The evaluations behind M2D2M's guided claims, sampling with guidance on ``guidance_on`` (``"x0"`` or
    ``"posterior"``): chapter 09's multi-motion table and TPS of the uniform model (s = 2), chapter 07's guidance rows
    (s = 0 and 4) and chapter 08's two arms (s = 4), by role: the scale study's ``m2d2m`` evaluations. Each config
    checks ``guidance_on``."""
    from .scale import group_evaluations

    roles = group_evaluations("m2d2m", profile)
    return {role: replace(config, guidance_on=guidance_on) for role, config in roles.items()}


def guidance_configs(guidance_on: str, profile: str | None = None) -> dict[str, dict[str, Any]]:
    """What a guidance-space record's numbers depend on besides the machine: ``{"models": ..., "evaluations": ...}``
    as JSON-ready dicts (the models of the ``m2d2m`` study, the evaluations of :func:`guidance_evaluations`)."""
    from motionlab.train.cache import config_dict

    profile = get_profile(profile)
    evaluations = guidance_evaluations(guidance_on, profile)
    return {
        "models": {name: config_dict(config) for name, config in _model_configs("m2d2m", profile).items()},
        "evaluations": {role: config_dict(config) for role, config in evaluations.items()},
    }


def guidance_changes(record: dict[str, Any], profile: str | None = None) -> list[str] | None:
    """Where a guidance-space record was measured with other configs than the code builds now (dotted paths); None
    where it holds none to compare."""
    recorded = record.get("configs")
    if not isinstance(recorded, dict) or "models" not in recorded or "guidance_on" not in record:
        return None
    return config_changes(recorded, guidance_configs(record["guidance_on"], profile))


# ------------------------------------------------------------------------------------ the budget study and the η axis
# ``experiments/m2d2m_budget.py``: the laptop text-to-motion models trained for other budgets (``t2m/<arm>-seed<k>-
# steps<n>``), or at other η (``t2m/eta<η>``), each scored at chapter 07's and chapter 09's sizes.
BUDGET_GUIDANCE_SCALES = (0.0, 1.0, 2.0, 4.0)
BUDGET_METHODS = ("independent", "tps", "tps:T_s=50", "handshake:transition=40")


def budget_evaluations(model: str, profile: str | None = None) -> dict[str, Any]:
    """The two evaluations that score a budget-study or η-axis ``model``: ``{"t2m": ..., "multi": ...}``, chapter
    07's single-motion table at guidance 0, 1, 2 and 4 and chapter 09's multi-motion table of four methods, at their
    sizes. Every model is scored with evaluation seed 0: the same captions, instances and sampling seeds."""
    from motionlab.evaluation.multi import MultiMotionConfig
    from motionlab.evaluation.t2m import TextToMotionConfig
    from motionlab.sizes import chapter_sizes

    sizes = chapter_sizes(get_profile(profile))
    t2m = TextToMotionConfig(
        models=(model,),
        guidance_scales=BUDGET_GUIDANCE_SCALES,
        limit=sizes.diffusion.eval_clips,
        repeats=sizes.diffusion.repeats,
        num_steps=sizes.diffusion.num_steps,
        seed=0,
    )
    multi = MultiMotionConfig(
        methods=BUDGET_METHODS,
        model=model,
        segment_jerk=True,
        instances=sizes.tps.instances,
        repeats=sizes.tps.repeats,
        num_steps=sizes.tps.num_steps,
        seed=0,
    )
    return {"t2m": t2m, "multi": multi}


def budget_model_config(record: dict[str, Any], profile: str | None = None) -> dict[str, Any]:
    """The resolved training config of a budget-study record's model (its ``arm``, ``steps`` and ``training_seed``)
    or of an η-axis record's (its ``eta``), as :func:`motionlab.models.load` trains it."""
    from motionlab.diffusion.training import budget_config, diffusion_training_config, with_overrides
    from motionlab.tokenizers import vq_config
    from motionlab.train.cache import config_dict

    profile = get_profile(profile)
    codes = vq_config(profile).codebook_size
    if "eta" in record:  # t2m/eta<η>: the profile's dynamic model at that η, training seed 0
        return config_dict(diffusion_training_config(profile, num_codes=codes, eta=float(record["eta"])))
    config = budget_config(profile, num_codes=codes, dynamic=record["arm"] == "dynamic", steps=int(record["steps"]))
    return config_dict(with_overrides(config, seed=int(record["training_seed"])))


def budget_changes(record: dict[str, Any], profile: str | None = None) -> list[str] | None:
    """Where a budget-study or η-axis record was measured with other configs than the code builds now: its model's
    (``"configs"``) and its two evaluations' (inside its tables). None where it holds no model config to compare."""
    from motionlab.train.cache import config_dict

    if "model" not in record.get("configs", {}):
        return None
    recorded = {"model": record["configs"]["model"], **{k: record[k]["config"] for k in ("t2m", "multi")}}
    evaluations = budget_evaluations(record["model"], profile)
    current = {"model": budget_model_config(record, profile), **{k: config_dict(v) for k, v in evaluations.items()}}
    return config_changes(recorded, current)
