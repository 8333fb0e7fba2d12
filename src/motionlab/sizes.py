"""How large each chapter's experiments are, per profile: the one place to read "how big is chapter 09's laptop run?".

Each chapter has a frozen dataclass whose defaults are its ``full`` size (the papers' protocol where there is one);
the smaller profiles override fields in one idiom, a dict of the fields that differ. :func:`chapter_sizes` builds
them for a profile, and :func:`motionlab.book.setup` hands them to a chapter as ``settings.sizes``::

    settings = book.setup(seed=seed, profile=profile)
    sizes = settings.sizes.tps          # TPSSizes(instances=32, repeats=3, ...) on the laptop profile

The models' sizes (widths, codebooks, training steps) and the run-wide ones (the embedded dataset, evaluation repeats)
follow the same idiom further down: each config class's defaults are the papers' (``full``), and a dict per model
holds the fields that the smaller profiles change; the config functions (``tokenizers.vq_config``,
``flow.discord_config``, ``diffusion.diffusion_training_config``, ...) apply them with :func:`resized`. The chapters
load those models by name (:func:`motionlab.models.load`) and never size them.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any

from motionlab.profiles import PROFILES, get_profile

# ------------------------------------------------------------------------------------------------ per chapter
# A block per chapter: the dataclass (full-size defaults), then its overrides for smoke and laptop.


@dataclass(frozen=True)
class MotionDataSizes:
    """Chapter 01 Motion as data."""

    animation_frames: int = 60  # frames per embedded animation (the page's weight grows with it)


MOTION_DATA = {"smoke": {"animation_frames": 40}, "laptop": {}}


@dataclass(frozen=True)
class VQSizes:
    """Chapter 02 Vector quantization."""

    animation_frames: int = 60


VQ = {"smoke": {"animation_frames": 40}, "laptop": {}}


@dataclass(frozen=True)
class FlowSizes:
    """Chapter 03 Rectified flow (2-D toy)."""

    points: int = 2000  # points per sample cloud in the measurements


FLOW = {"smoke": {"points": 500}, "laptop": {}}


@dataclass(frozen=True)
class ProjectionSizes:
    """Chapter 04 Condition projection."""

    windows: int = 512  # held-out 64-frame windows for the flow loss of each projection
    clips: int = 256  # test clips decoded by each ablation decoder


PROJECTION = {"smoke": {"windows": 8, "clips": 3}, "laptop": {"windows": 128, "clips": 64}}


@dataclass(frozen=True)
class DiscordSizes:
    """Chapter 05 DisCoRD."""

    seeds: int = 20  # sampling seeds of the DisCoRD rows (the papers repeat 20 times)
    test_clips: int | None = None  # None: the whole test split
    timing_repeats: int = 5  # timed calls per decoder (Table E)
    euler_steps: tuple[int, ...] = (1, 2, 4, 8, 16)  # Table E's Euler rows (intervals)
    midpoint_steps: tuple[int, ...] = (1, 2, 4, 8, 15)  # the paper's 2, 3, 5, 9, 16 "steps" (grid points)
    grid_seeds: int = 1  # sampling seeds of each Table E row: the first of Table 1's
    sweep_profile: bool = False  # the committed sweeps measured this profile's data and chose its decoder
    animation_frames: int = 60


DISCORD = {
    "smoke": {"seeds": 2, "timing_repeats": 3, "animation_frames": 40},
    "laptop": {"seeds": 3, "test_clips": 160, "timing_repeats": 3, "sweep_profile": True},
}


@dataclass(frozen=True)
class SJPESizes:
    """Chapter 06 sJPE."""

    noise_draws: int = 3  # noise draws per sigma (the intervals are over these draws)
    partners: int = 1  # random partner draws per clip for the seam Jerk (M2D2M Table 1's concatenated row)


SJPE = {"smoke": {"noise_draws": 2, "partners": 2}, "laptop": {}}


@dataclass(frozen=True)
class DiffusionSizes:
    """Chapter 07 Discrete diffusion (text-to-motion, M2D2M Table 3)."""

    eval_clips: int | None = None  # None: the whole test split
    repeats: int = 20
    num_steps: int | None = None  # sampling steps; None: all T
    guidance_scales: tuple[float, ...] = (0.0, 1.0, 2.0, 4.0)  # one Table 3 row each (s = 0 and M2D2M's 4 printed)
    mm_texts: int = 100  # MultiModality texts
    mm_repeats: int = 30  # generations per MultiModality text (the T2M protocol: 100 texts x 30)
    entropy_clips: int = 512
    demo_texts: int = 16
    animation_frames: int = 60


DIFFUSION = {
    "smoke": {
        "eval_clips": 48,
        "repeats": 2,
        "num_steps": 10,
        "mm_texts": 4,
        "mm_repeats": 10,
        "entropy_clips": 16,
        "demo_texts": 8,
        "animation_frames": 40,
    },
    "laptop": {
        "eval_clips": 256,
        "repeats": 3,
        "num_steps": 25,
        "mm_texts": 24,
        "mm_repeats": 10,
        "entropy_clips": 128,
    },
}


@dataclass(frozen=True)
class TransitionsSizes:
    """Chapter 08 Dynamic transitions."""

    eval_clips: int | None = None
    repeats: int = 20
    num_steps: int | None = None
    guidance_scale: float = 4.0  # M2D2M's s for single motions, every model alike
    training_seeds: tuple[int, ...] = (
        0,
        1,
        2,
    )  # per arm, trained by the book; seed 0 is the model chapters 07, 09 share
    sweep_etas: tuple[float, ...] = (0.0, 0.25, 0.5, 2.0, 8.0)  # one model per η at training seed 0
    distance_ablation: bool = True  # one more model per distance function

    def __post_init__(self):
        seeds = tuple(self.training_seeds)  # a papermill parameter arrives as a list
        if not seeds or seeds[0] != 0 or len(set(seeds)) != len(seeds):
            raise ValueError(
                f"training_seeds must be distinct and start with 0 (the model the other chapters share), got {seeds}"
            )
        object.__setattr__(self, "training_seeds", tuple(int(s) for s in seeds))
        object.__setattr__(self, "sweep_etas", tuple(float(e) for e in self.sweep_etas))

    def override(self, **choices: Any) -> TransitionsSizes:
        """These sizes with a chapter's parameters applied; a choice of None keeps the profile's value."""
        return replace(self, **{name: value for name, value in choices.items() if value is not None})


TRANSITIONS = {
    "smoke": {
        "eval_clips": 48,
        "repeats": 2,
        "num_steps": 10,
        "sweep_etas": (0.0, 0.25, 0.5),
        "distance_ablation": False,
    },
    "laptop": {
        "eval_clips": 256,
        "repeats": 3,
        "num_steps": 25,
        # Seed 0 of each arm only: the replicates are the training-seed study's (experiments/training_seeds.py
        # --study transitions, recorded under book/data/training_seeds/), whose spread joins the verdict. Training
        # and scoring them in every build cost 16 of its 135 CPU-minutes on an AVX2-only CPU in fp32 (2026-12-03).
        "training_seeds": (0,),
        "sweep_etas": (0.0, 0.25, 0.5),
        "distance_ablation": False,
    },
}


@dataclass(frozen=True)
class TPSSizes:
    """Chapter 09 Two-Phase Sampling (multi-motion, M2D2M Tables 1, 5, 6)."""

    instances: int | None = None  # multi-action test instances of the generated rows; None: every one
    repeats: int = 20
    num_steps: int | None = None
    widget_ts: tuple[int, ...] = (100, 95, 90, 80, 50, 25, 0)
    widget_actions: tuple[int, ...] = (2, 3, 4, 6, 8)
    animation_frames: int = 60


TPS = {
    "smoke": {
        "instances": 4,
        "repeats": 1,
        "num_steps": 10,
        "widget_ts": (100, 90, 50, 0),
        "widget_actions": (2, 3, 4),
        "animation_frames": 40,
    },
    "laptop": {
        "instances": 32,
        "repeats": 3,
        "num_steps": 25,
        "widget_ts": (100, 95, 90, 75, 50, 25, 0),
        "widget_actions": (2, 3, 4, 5, 6),
    },
}


# ------------------------------------------------------------------------------------------------ run-wide
@dataclass(frozen=True)
class RunSizes:
    """What every chapter and command of a run shares."""

    embedded_clips: int = 6000  # clips of the embedded procedural dataset (HumanML3D's test split has 4,384)
    evaluation_repeats: int = 20  # repeats of a sampled row in `motionlab evaluate` (the papers repeat 20 times)


RUN = {
    "smoke": {"embedded_clips": 420, "evaluation_repeats": 2},
    "laptop": {"embedded_clips": 3000, "evaluation_repeats": 5},
}


# ------------------------------------------------------------------------------------------------ models
# Fields of each model's config that smoke and laptop change; its class's defaults are the papers' sizes. A dict
# value changes fields of a nested config (a tokenizer's ``train``) and keeps the rest of it. Every model's cache key
# hashes its whole config: changing a number here retrains that model for every reader.

# VQConfig / RVQConfig (tokenizers/config.py). Both small profiles train with a cosine schedule, so the published
# multistep milestones are cleared; no dropout and no Gumbel sampling (MoMask's) at these lengths.
TOKENIZER = {
    "smoke": {
        "width": 32,
        "depth": 1,
        "code_dim": 16,
        "codebook_size": 32,
        "window": 16,
        "batch_size": 8,
        "dropout": 0.0,
        "gumbel_temperature": 0.0,
        "train": {
            "steps": 40,
            "lr": 2e-3,
            "schedule": "cosine",
            "warmup_steps": 5,
            "milestones": (),
            "gamma": 0.1,
            "log_every": 10,
            "ckpt_every": 0,
        },
    },
    "laptop": {
        "width": 128,
        "depth": 2,
        "code_dim": 64,
        "codebook_size": 256,
        "window": 64,
        "batch_size": 32,
        "dropout": 0.0,
        "gumbel_temperature": 0.0,
        "train": {
            "steps": 2000,
            "lr": 1e-3,
            "schedule": "cosine",
            "warmup_steps": 100,
            "min_lr_ratio": 0.05,
            "milestones": (),
            "gamma": 0.1,
            "grad_clip": 1.0,
            "log_every": 50,
            "ckpt_every": 500,
        },
    },
}
RVQ_TOKENIZER = {"smoke": {**TOKENIZER["smoke"], "num_layers": 3}, "laptop": TOKENIZER["laptop"]}

# DisCoRDConfig (flow/config.py). Smoke: seconds of training, code width = the smoke tokenizer's. Laptop: the paper's
# protocol (velocity prediction, t ~ U(0, 1), start noise N(0, I), 15 midpoint intervals = the paper's 16 grid points)
# at the width and budget a laptop build affords. Width 128 and 4,000 steps at lr 3e-3 were chosen by measurement for
# the x-predicting variant below (study s1, experiments/discord_sweep.py: under 10 minutes of training on one core of
# a 2-core machine the paper's width-272 U-Net got ~420 steps and stayed rough; at width 128, 0.16 s per bf16 step on
# an AMD EPYC with AVX512-BF16, 4,000 steps are about 11 CPU-minutes); the paper's decoder keeps them, so that the
# two differ only in the levers DISCORD_XPRED names. What that costs (chapter 05, 160 test clips, bf16, AMD EPYC Zen 4,
# 2026-12-07): sJPE 3.50 against the feed-forward decoder's 1.45 and the variant's 1.38. Below the motion's 263 features
# a velocity U-Net cannot see part of its start noise (a t = 0 loss floor of (263 - 128)/263 = 0.51, study s1), so at
# this width the paper's decoder does not hold at any budget. Above 263 only the budget bars it: study s1 trained it at
# width 272 for 40 minutes of one core (v-40min, validation, bf16); at temperature 1 it still scored sJPE 2.66 against
# the feed-forward decoder's 1.44, from zero noise it fell below 1.44 within 10 minutes. It trains a third as many steps
# per minute as width 128, more than the build's 30 minutes allow. Normalisation stays the tokenizer's ("std", not
# feat_bias): study s7 (Where the laptop departs from the papers) weighs each departure.
DISCORD_DECODER = {
    "smoke": {
        "code_dim": 16,
        "cond_dim": 16,
        "width": 16,
        "sample_steps": 4,
        "solver": "euler",
        "window": 16,
        "batch_size": 16,
        "lr": 1e-3,
        "min_lr": 1e-4,
        "train_steps": 60,
        "warmup_steps": 5,
        "ema_decay": 0.9,
    },
    "laptop": {
        "code_dim": 64,
        "cond_dim": 64,
        "width": 128,
        "width_mults": (1, 1),
        "sample_steps": 15,
        "solver": "midpoint",
        "normalization": "std",
        "batch_size": 32,
        "lr": 3e-3,
        "train_steps": 4000,
        "warmup_steps": 200,
        "ema_decay": 0.995,
    },
}
# The laptop's x-predicting variant of chapter 05's decoder (``discord/rvq-xpred``), on top of DISCORD_DECODER: the
# network predicts the clean motion and sampling starts from zero noise (temperature 0) with 8 midpoint intervals.
# Study s1 chose it when the book's decoder had to train in 10 CPU-minutes: on validation (data v2) it scored sJPE 2.86
# at temperature 1 and 1.60 at 0, the paper's velocity U-Net 3.66 and 1.68, the feed-forward decoder 1.40. It is a
# lever, not the paper: no verdict rests on it; chapter 05 shows its Table 1 beside the paper's decoder.
XPRED_LEVERS = {"prediction": "x", "temperature": 0.0}  # the variant at any profile (full: on the paper's sizes)
DISCORD_XPRED = {"smoke": XPRED_LEVERS, "laptop": {**XPRED_LEVERS, "sample_steps": 8}}
# Chapter 04's three projection-ablation decoders, on top of DISCORD_DECODER: at chapter 05's full budget the three
# would add more than half to the book's training time; at a quarter of this one (tried while sizing the build) they
# were far from converged and the ablation meaningless. Warm-up stays 5% of the steps. The U-Net is half chapter 05's
# width: the three compare with each other, not with the feed-forward decoder, and at width 128 they cost 21.9 of the
# laptop build's 108 CPU-minutes on an AVX2-only CPU in fp32 (0.36-0.41 s per step); at 64, 8.4 in a cold build
# (0.14-0.15 s per step, 2026-12-03), with the claim they carry (Table 6) inconclusive at either width.
DISCORD_ABLATION = {"smoke": {}, "laptop": {"width": 64, "train_steps": 1150, "warmup_steps": 57}}
# The DisCoRD decoder of the single-codebook VQ tokens (``discord/vq``: chapter 09 and ``--decoder discord``), on top
# of DISCORD_DECODER. No claim is judged on it: it shows that DisCoRD decodes M2D2M's tokens unchanged. At chapter 05's
# 4,000 steps and width 128 it cost 19.8 of the laptop build's 135 CPU-minutes on an AVX2-only CPU in fp32
# (2026-12-03); at the ablation's budget and width it keeps the chapter's comparison (its own decoder against the VQ
# decoder, inside the actions and at the seams) and costs 2.8. The ``full`` profile trains it like chapter 05's.
DISCORD_VQ = {"smoke": {}, "laptop": DISCORD_ABLATION["laptop"]}

# TransformerConfig (diffusion/transformer.py), the denoiser. Laptop: about 3 minutes on one core of an AVX2-only CPU in
# fp32 (800 steps of ~0.19 s; the laptop book trains three such models, see motionlab.build.book_models). The learning
# rates are larger than the paper's 2e-4: these runs are hundreds of steps, not 110 epochs.
DENOISER = {
    "smoke": {
        "n_layers": 2,
        "n_heads": 2,
        "d_model": 32,
        "d_ff": 64,
        "rel_buckets": 16,
        "rel_max_distance": 32,
        "batch_size": 16,
        "train_steps": 150,
        "lr": 2e-3,
        "lr_decayed": 2e-4,
    },
    "laptop": {
        "n_layers": 3,
        "n_heads": 4,
        "d_model": 128,
        "d_ff": 256,
        "rel_buckets": 32,
        "rel_max_distance": 64,
        "batch_size": 32,
        "train_steps": 800,
        "lr": 1e-3,
        "lr_decayed": 1e-4,
    },
}
# WordEncoderConfig and DiffusionTrainingConfig (diffusion/training.py): the text encoder trained beside it, and the
# rest of its training.
WORD_ENCODER = {"smoke": {"dim": 32, "n_layers": 1, "n_heads": 2}, "laptop": {"dim": 128, "n_layers": 1, "n_heads": 4}}
DIFFUSION_TRAINING = {"smoke": {"warmup_steps": 10, "log_every": 10}, "laptop": {"warmup_steps": 100, "log_every": 50}}

# EvaluatorTrainingConfig (metrics/evaluator_training.py): the text-motion evaluator trained on the embedded data
# (full: the official networks, which real HumanML3D replaces with the released weights).
EVALUATOR = {
    "smoke": {
        "evaluator": {
            "dim_word": 32,
            "dim_text_hidden": 32,
            "dim_motion_hidden": 48,
            "dim_coemb": 32,
            "dim_movement_hidden": 48,
            "dim_movement_latent": 48,
        },
        "steps": 120,
        "lr": 2e-3,
        "grad_clip": 1.0,
        "val_every": 40,
    },
    "laptop": {
        "evaluator": {
            "dim_word": 64,
            "dim_text_hidden": 128,
            "dim_motion_hidden": 128,
            "dim_movement_hidden": 128,
            "dim_movement_latent": 128,
        },
        "steps": 800,
        "lr": 1e-3,
        "grad_clip": 1.0,
        "val_every": 200,
    },
}

# ToyFlowConfig (flow/toy.py), chapter 03's 2-D flow: only the training length changes.
TOY_FLOW = {"smoke": {"steps": 300}, "laptop": {"steps": 5000}}

MODEL_TABLES = {
    "tokenizer/vq": TOKENIZER,
    "tokenizer/rvq": RVQ_TOKENIZER,
    "discord": DISCORD_DECODER,
    "discord/ablation": DISCORD_ABLATION,
    "discord/vq": DISCORD_VQ,
    "discord/xpred": DISCORD_XPRED,
    "denoiser": DENOISER,
    "word_encoder": WORD_ENCODER,
    "diffusion_training": DIFFUSION_TRAINING,
    "evaluator": EVALUATOR,
    "toy_flow": TOY_FLOW,
}


def resized(config: Any, table: dict[str, dict[str, Any]], profile: str | None = None) -> Any:
    """``config`` (a dataclass, its ``full`` size) with ``table``'s changes for ``profile`` applied.

    A dict value changes the named fields of the nested config it replaces and keeps its others."""
    profile = get_profile(profile)
    changes = {}
    for name, value in table.get(profile, {}).items():
        if name not in {f.name for f in fields(config)}:
            raise ValueError(f"{profile} sizes name {name!r}, not a field of {type(config).__name__}")
        changes[name] = resized(getattr(config, name), {profile: value}, profile) if isinstance(value, dict) else value
    return replace(config, **changes)


def run_sizes(profile: str | None = None) -> RunSizes:
    """The :class:`RunSizes` of ``profile`` (default: the run's, ``$MOTIONLAB_PROFILE``)."""
    return resized(RunSizes(), RUN, profile)


@dataclass(frozen=True)
class Sizes:
    """Every chapter's sizes for one profile (``settings.sizes``)."""

    profile: str
    run: RunSizes
    motion_data: MotionDataSizes
    vq: VQSizes
    flow: FlowSizes
    projection: ProjectionSizes
    discord: DiscordSizes
    sjpe: SJPESizes
    diffusion: DiffusionSizes
    transitions: TransitionsSizes
    tps: TPSSizes

    @property
    def checks_results(self) -> bool:
        """Whether the chapter asserts what its results show (not in ``smoke``: there the numbers only prove the code
        runs, from models trained for seconds)."""
        return self.profile != "smoke"


_CHAPTERS: dict[str, tuple[type, dict[str, dict[str, Any]]]] = {
    "motion_data": (MotionDataSizes, MOTION_DATA),
    "vq": (VQSizes, VQ),
    "flow": (FlowSizes, FLOW),
    "projection": (ProjectionSizes, PROJECTION),
    "discord": (DiscordSizes, DISCORD),
    "sjpe": (SJPESizes, SJPE),
    "diffusion": (DiffusionSizes, DIFFUSION),
    "transitions": (TransitionsSizes, TRANSITIONS),
    "tps": (TPSSizes, TPS),
}


def chapter_sizes(profile: str | None = None) -> Sizes:
    """The :class:`Sizes` of ``profile`` (default: the run's, ``$MOTIONLAB_PROFILE``)."""
    profile = get_profile(profile)
    parts = {}
    for name, (kind, overrides) in _CHAPTERS.items():
        unknown = set(overrides) - set(PROFILES)
        if unknown:
            raise ValueError(f"{name}: overrides for unknown profiles {sorted(unknown)}")
        known = {f.name for f in fields(kind)}
        changes = overrides.get(profile, {})
        bad = set(changes) - known
        if bad:
            raise ValueError(f"{name}: {profile} overrides {sorted(bad)}, not fields of {kind.__name__}")
        parts[name] = replace(kind(), **changes)
    return Sizes(profile=profile, run=run_sizes(profile), **parts)


__all__ = [
    "DiffusionSizes",
    "DiscordSizes",
    "FlowSizes",
    "MotionDataSizes",
    "ProjectionSizes",
    "RunSizes",
    "SJPESizes",
    "Sizes",
    "TPSSizes",
    "TransitionsSizes",
    "VQSizes",
    "chapter_sizes",
    "resized",
    "run_sizes",
]
