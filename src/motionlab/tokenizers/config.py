"""Tokenizer configurations per run profile.

The defaults are the published setting (T2M-GPT for :class:`VQConfig`, MoMask for :class:`RVQConfig`, the ``full``
profile); ``laptop`` keeps the architecture but shrinks widths and codebooks so a few minutes on 2 CPU cores give a
usable tokenizer; ``smoke`` only proves the code runs. Their changes live in :mod:`motionlab.sizes`
(``TOKENIZER``, ``RVQ_TOKENIZER``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

from ..sizes import RVQ_TOKENIZER, TOKENIZER, resized
from ..train import TrainConfig


@dataclass
class VQConfig:
    """One-codebook VQ-VAE (T2M-GPT; M2D2M uses the same tokenizer)."""

    feature_dim: int = 263
    n_joints: int = 22  # sets the ric dims of the loss
    width: int = 512
    depth: int = 3  # residual blocks per resolution
    dilation_growth: int = 3
    dropout: float = 0.0  # inside residual blocks (MoMask: 0.2)
    code_dim: int = 512
    codebook_size: int = 512
    ema_decay: float = 0.99
    reset_threshold: float = 1.0  # EMA count below which a code is re-initialised
    gumbel_temperature: float = 0.0  # > 0: sample codes while training (MoMask: 0.5)
    ric_weight: float = 0.5
    commit_weight: float = 0.02
    window: int = 64  # training crop length in frames
    batch_size: int = 256
    seed: int = 0  # weight initialisation and codebook draws
    train: TrainConfig = field(
        default_factory=lambda: TrainConfig(
            steps=300_000,
            lr=2e-4,
            betas=(0.9, 0.99),
            weight_decay=0.0,
            schedule="multistep",
            warmup_steps=1000,
            milestones=(200_000,),
            gamma=0.05,
            log_every=100,
            ckpt_every=5000,
        )
    )

    def __post_init__(self):
        if self.window % 4:
            raise ValueError(f"window must be a multiple of 4, got {self.window}")
        if 4 + 3 * (self.n_joints - 1) > self.feature_dim:
            raise ValueError(f"n_joints={self.n_joints} does not fit feature_dim={self.feature_dim}")


@dataclass
class RVQConfig(VQConfig):
    """Residual VQ-VAE (MoMask ``rvq_nq6_dc512_nc512_noshare_qdp0.2``, the tokenizer DisCoRD decodes)."""

    num_layers: int = 6
    quantize_dropout: float = 0.2
    dropout: float = 0.2
    gumbel_temperature: float = 0.5
    # MoMask: 50 epochs of all windows (≈ 300k iterations at batch 256 is our estimate), lr ×0.05 at 150k and 250k
    train: TrainConfig = field(
        default_factory=lambda: TrainConfig(
            steps=300_000,
            lr=2e-4,
            betas=(0.9, 0.99),
            weight_decay=0.0,
            schedule="multistep",
            warmup_steps=2000,
            milestones=(150_000, 250_000),
            gamma=0.05,
            log_every=100,
            ckpt_every=5000,
        )
    )


def _with(config, overrides: dict):
    unknown = sorted(set(overrides) - {f.name for f in fields(config)})
    if unknown:
        raise ValueError(f"unknown {type(config).__name__} field(s): {', '.join(unknown)}")
    return replace(config, **overrides)


def vq_config(profile: str | None = None, **overrides) -> VQConfig:
    """The :class:`VQConfig` of a profile (``smoke`` | ``laptop`` | ``full``), with field overrides."""
    return _with(resized(VQConfig(), TOKENIZER, profile), overrides)


def rvq_config(profile: str | None = None, **overrides) -> RVQConfig:
    """The :class:`RVQConfig` of a profile (``smoke`` | ``laptop`` | ``full``), with field overrides."""
    return _with(resized(RVQConfig(), RVQ_TOKENIZER, profile), overrides)
