"""How large each chapter's experiments are, per profile: the one place to read "how big is chapter 09's laptop run?".

Each chapter has a frozen dataclass whose defaults are its ``full`` size (the papers' protocol where there is one);
the smaller profiles override fields in one idiom, a dict of the fields that differ. :func:`chapter_sizes` builds
them for a profile, and :func:`motionlab.book.setup` hands them to a chapter as ``settings.sizes``::

    settings = book.setup(seed=seed, profile=profile)
    sizes = settings.sizes.tps          # TPSSizes(instances=32, repeats=3, ...) on the laptop profile

The sizes of the models themselves (widths, training steps) live with their configs (``flow/config.py``,
``tokenizers/config.py``, ``diffusion/training.py``, ``metrics/evaluator_training.py``): the chapters load those
models by name (:func:`motionlab.models.load`) and never size them.
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
    training_seeds: tuple[int, ...] = (0, 1, 2)  # per arm; seed 0 is the model chapters 07 and 09 share
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


@dataclass(frozen=True)
class Sizes:
    """Every chapter's sizes for one profile (``settings.sizes``)."""

    profile: str
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
    return Sizes(profile=profile, **parts)


__all__ = [
    "DiffusionSizes",
    "DiscordSizes",
    "FlowSizes",
    "MotionDataSizes",
    "ProjectionSizes",
    "SJPESizes",
    "Sizes",
    "TPSSizes",
    "TransitionsSizes",
    "VQSizes",
    "chapter_sizes",
]
