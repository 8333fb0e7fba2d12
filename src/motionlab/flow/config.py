"""DisCoRD decoder configurations, one per run profile (smoke / laptop / full).

The defaults of :class:`DisCoRDConfig` (the ``full`` profile) are the paper's Table A (HumanML3D, MoMask RVQ tokens)
plus what the public training script does where the table is silent:

=====================  ===========================================================================
U-Net                   width 512, mults (1, 2) → dims [512, 512, 1024], 1 ResNet per level (2 conv
                        blocks each), no attention, dropout 0; input 263 features ‖ 256 condition
Condition projection    "stacked": 512 ·4 → 2048 → 2048, then 512 → 256 per frame.
                        U-Net + projection = 66.9 M parameters (Table A: 66.9 M)
Training                window 64, batch 768, AdamW (0.9, 0.999), torch-default weight decay 0.01,
                        lr 5e-4, cosine to 1e-5 with 20 of 200 epochs warm-up (481,896 steps in all,
                        so ≈ 48,190 warm-up steps), grad-norm clip 1.0, EMA 0.999, MSE flow loss
Sampling                16-point grid with midpoint = 15 intervals = 30 network evaluations, from unit
                        Gaussian noise (temperature 1)
Parameterisation        velocity prediction, t ~ U(0, 1), MSE on the velocity; features normalised by
                        MoMask's Mean/Std with the root (dims 0–3) and foot-contact (last 4) std divided
                        by 25 (``feat_bias``), which motionlab applies inside the decoder
                        (``normalization="feat_bias"``: the decoder's own space is the tokenizer's ×25 there)
=====================  ===========================================================================

The options the paper does not use (``prediction="x"``, a logit-normal time distribution, a start-noise
``temperature`` below 1, a ``data_dense`` grid, ``final_prediction``) are the levers chapter 05 measures at
laptop scale; see :mod:`motionlab.flow.rectified_flow`.

``feature_dim`` and ``code_dim`` must match the tokenizer; pass it (or overrides) to :func:`discord_config`. What
the smoke and laptop profiles change, and why, is ``DISCORD_DECODER`` in :mod:`motionlab.sizes`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from motionlab.flow.condition import CONDITION_PROJECTIONS
from motionlab.flow.rectified_flow import GRIDS, PREDICTIONS, SOLVERS, TIME_DISTRIBUTIONS, ODESolver
from motionlab.flow.unet1d import UNetConfig
from motionlab.sizes import DISCORD_DECODER, resized
from motionlab.train import TrainConfig

NORMALIZATIONS = ("std", "feat_bias")
FEAT_BIAS = 25.0  # MoMask's feat_bias: the root and foot-contact std is divided by this


def check_temperature(value: Any) -> float:
    """A start-noise temperature as a float; it must be finite and >= 0."""
    try:
        temperature = float(value)
    except (TypeError, ValueError):
        temperature = float("nan")
    if not (math.isfinite(temperature) and temperature >= 0):
        raise ValueError(f"temperature must be a finite number >= 0, got {value!r}")
    return temperature


@dataclass(frozen=True)
class DisCoRDConfig:
    # --- model
    feature_dim: int = 263  # D: 263 HumanML3D, 251 KIT
    code_dim: int = 512  # d: the tokenizer's code vector width
    q: int = 4  # frames per token (the tokenizer's temporal downsampling)
    cond_dim: int = 256  # c: frame-wise condition width
    projection: str = "stacked"  # one of CONDITION_PROJECTIONS
    width: int = 512
    width_mults: tuple[int, ...] = (1, 2)
    resnets_per_level: int = 1
    dropout: float = 0.0
    seed: int = 0  # weight initialisation: a decoder is a pure function of its config
    # --- parameterisation (fixed at training time: a decoder trained one way cannot be read another)
    prediction: str = "v"  # the network outputs the velocity ("v", the paper's) or the clean motion ("x")
    normalization: str = "feat_bias"  # "std": the tokenizer's space; "feat_bias": root/contact dims ×25
    time_distribution: str = "uniform"  # training times: "uniform" (the paper's) or "logit_normal"
    time_loc: float = 0.0  # logit-normal location (> 0: more training near the data end)
    time_scale: float = 1.0  # logit-normal scale
    # --- sampling (the decode() defaults)
    sample_steps: int = 15  # integration intervals: 16 grid points
    solver: str = "midpoint"
    spacing: str = "uniform"  # the time grid: "uniform" or "data_dense"
    temperature: float = 1.0  # start-noise scale: x0 ~ N(0, temperature² I) (the paper: 1)
    final_prediction: bool = False  # x-prediction only: the last interval returns the network's x̂1
    # --- training (consumed by the shared trainer)
    window: int = 64  # frames per training window (= window / q tokens)
    batch_size: int = 768
    lr: float = 5e-4
    min_lr: float = 1e-5
    betas: tuple[float, float] = (0.9, 0.999)
    weight_decay: float = 0.01
    train_steps: int = 481_896
    warmup_steps: int = 48_190
    ema_decay: float = 0.999
    grad_clip: float = 1.0

    def __post_init__(self) -> None:
        if self.projection not in CONDITION_PROJECTIONS:
            raise ValueError(f"projection must be one of {CONDITION_PROJECTIONS}, got {self.projection!r}")
        for name, choices in (
            ("solver", SOLVERS),
            ("prediction", PREDICTIONS),
            ("normalization", NORMALIZATIONS),
            ("time_distribution", TIME_DISTRIBUTIONS),
            ("spacing", GRIDS),
        ):
            if getattr(self, name) not in choices:
                raise ValueError(f"{name} must be one of {choices}, got {getattr(self, name)!r}")
        check_temperature(self.temperature)
        if not self.time_scale > 0:
            raise ValueError(f"time_scale must be > 0, got {self.time_scale!r}")
        if self.final_prediction and self.prediction != "x":
            raise ValueError("final_prediction returns the network's x̂1: it needs prediction='x'")
        if self.window % self.q or self.window % self.unet.length_multiple:
            raise ValueError(f"window={self.window} must be a multiple of q={self.q} and of the U-Net stride")
        if not 0.0 <= self.ema_decay < 1.0:
            raise ValueError(f"ema_decay must be in [0, 1), got {self.ema_decay}")
        ODESolver(self.sample_steps, self.solver)  # validates sample_steps

    @property
    def unet(self) -> UNetConfig:
        """The vector-field network's config; lengths must hold whole tokens and survive the halvings."""
        return UNetConfig(
            feature_dim=self.feature_dim,
            cond_dim=self.cond_dim,
            width=self.width,
            width_mults=tuple(self.width_mults),
            resnets_per_level=self.resnets_per_level,
            dropout=self.dropout,
            length_multiple=math.lcm(self.q, 2 ** (len(self.width_mults) - 1)),
        )

    @property
    def tokens_per_window(self) -> int:
        return self.window // self.q

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def train_config(self, **overrides: Any) -> TrainConfig:
        """The shared trainer's settings: AdamW, linear warm-up then cosine to ``min_lr``, clip, EMA."""
        settings: dict[str, Any] = dict(
            steps=self.train_steps,
            lr=self.lr,
            betas=self.betas,
            weight_decay=self.weight_decay,
            schedule="cosine",
            warmup_steps=self.warmup_steps,
            min_lr_ratio=self.min_lr / self.lr,
            grad_clip=self.grad_clip,
            ema_decay=self.ema_decay,
        )
        return TrainConfig(**{**settings, **overrides})


def discord_config(profile: str | None = None, tokenizer: Any = None, **overrides: Any) -> DisCoRDConfig:
    """The config for ``profile`` (see :mod:`motionlab.profiles`), matched to ``tokenizer`` if given.

    A tokenizer sets ``feature_dim``, ``code_dim`` and ``q`` (its ``downsample``); ``overrides`` win last.
    """
    config = resized(DisCoRDConfig(), DISCORD_DECODER, profile)
    if tokenizer is not None:
        config = replace(
            config,
            feature_dim=int(tokenizer.feature_dim),
            code_dim=int(tokenizer.code_dim),
            q=int(tokenizer.downsample),
        )
    unknown = set(overrides) - set(DisCoRDConfig.__dataclass_fields__)
    if unknown:
        raise ValueError(f"unknown DisCoRDConfig fields: {sorted(unknown)}")
    return replace(config, **overrides)
