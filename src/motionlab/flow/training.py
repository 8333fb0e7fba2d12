"""Training DisCoRD's decoder on the tokens of a frozen tokenizer, and the train-once cache chapters load from.

    windows x1 (B, W, D) of normalised train clips     (W = 64 frames: every stride-1 window, drawn uniformly)
    Z = tokenizer.embed(tokenizer.encode(x1))           (B, W/q, d)    the frozen tokenizer's code vectors
    loss = E ‖(x1 − x0) − v(t·x1 + (1 − t)·x0, t, C(Z))‖²          (:func:`~motionlab.flow.discord_loss_fn`)

The tokenizer never trains here. Its ``encode`` is a nearest-code argmin, so a window's code vectors are a
fixed function of the window: encoding a window when the batch is drawn gives exactly what the public code
gets by encoding every window once ahead of training, without storing a code sequence per window.

The shared :class:`~motionlab.train.Trainer` runs the optimisation with the config's ``train_config()``
(AdamW, warm-up then cosine, grad-norm clip, EMA); the decoder that is cached and returned carries the
EMA weights. A trained decoder is addressed by the dataset, the tokenizer and the whole DisCoRD config.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import Tensor

from motionlab.flow.config import DisCoRDConfig, discord_config
from motionlab.flow.discord import DisCoRDDecoder, discord_loss_fn
from motionlab.profiles import get_profile
from motionlab.train import Trainer, WindowDataset, load_result, train_or_load
from motionlab.train.cache import artefact_key
from motionlab.train.compiling import compile_for_training, release_compiled

MODEL_NAME = "discord"
Clips = Sequence[np.ndarray]


# ----------------------------------------------------------------------------- data


@torch.no_grad()
def code_vectors(tokenizer: Any, motion: Tensor) -> Tensor:
    """The frozen tokenizer's code vectors of normalised motion: ``(B, T, D) -> (B, T/q, d)``.

    For a residual tokenizer this is the sum of all layers' codes (what DisCoRD conditions on). On the tokenizer's
    device.
    """
    return tokenizer.embed(tokenizer.encode(motion)).detach()


class TokenWindowBatches:
    """``batch_fn(step, generator) -> (motion (B, W, D), code vectors (B, W/q, d))`` for the trainer.

    ``to(device)`` moves the windows and the frozen tokenizer there, so windows are gathered and encoded on the
    training device (no copy of the batch at each step).
    """

    def __init__(self, windows: WindowDataset, tokenizer: Any, batch_size: int) -> None:
        if batch_size < 1:
            raise ValueError(f"batch_size must be >= 1, got {batch_size}")
        self.windows, self.tokenizer, self.batch_size = windows, tokenizer, batch_size

    def to(self, device: str | torch.device) -> TokenWindowBatches:
        self.windows.to(device)
        self.tokenizer.to(device)
        return self

    def __call__(self, step: int, generator: torch.Generator) -> tuple[Tensor, Tensor]:
        motion = self.windows.sample(self.batch_size, generator)  # (B, W, D), where the windows live
        return motion, code_vectors(self.tokenizer, motion)


def token_window_batches(windows: WindowDataset, tokenizer: Any, batch_size: int) -> TokenWindowBatches:
    """A ``batch_fn(step, generator) -> (motion (B, W, D), code vectors (B, W/q, d))`` for the trainer."""
    return TokenWindowBatches(windows, tokenizer, batch_size)


def flow_validation(tokenizer: Any, clips: Clips, window: int, n_windows: int = 64, seed: int = 0) -> Callable:
    """A ``val_fn`` giving the flow-matching loss on fixed held-out windows with fixed noise and times.

    The same windows, ``x0`` and ``t`` at every call, so the curve moves only because the weights do.
    """
    data = WindowDataset(clips, window)
    motion = data.sample(min(n_windows, len(data)), torch.Generator().manual_seed(seed))  # (n, W, D)
    codes = code_vectors(tokenizer, motion).cpu()  # (n, W/q, d)

    @torch.no_grad()
    def val_fn(model: DisCoRDDecoder) -> dict[str, float]:
        device = next(model.parameters()).device
        noise = torch.Generator().manual_seed(seed + 1)
        return {"loss": float(model.loss(motion.to(device), codes.to(device), noise))}

    return val_fn


@torch.no_grad()
def loss_at_time(model: DisCoRDDecoder, motion: Tensor, codes: Tensor, t: float, generator: torch.Generator) -> float:
    """The flow-matching loss with every ``t`` fixed: ``mean((x1 − x0) − v(t·x1 + (1 − t)·x0, t, C))²``.

    ``motion (B, T, D)`` and its ``codes (B, T/q, d)``; ``x0`` is drawn from ``generator``. The loss as a
    function of ``t`` shows where the error lives: at t = 0 the motion must come from the codes alone (and
    all of ``x0`` must pass through the network); at t = 1 ``x0`` is gone from the input, so the loss is ≥ 1.
    """
    if not 0.0 <= t <= 1.0:
        raise ValueError(f"t must be in [0, 1], got {t}")
    device = next(model.parameters()).device
    x1, codes = model.to_model_space(motion.to(device)), codes.to(device)
    x0 = torch.randn(x1.shape, generator=generator, device=generator.device).to(device)
    times = torch.full((x1.shape[0],), float(t), device=device)
    v = model.velocity(t * x1 + (1.0 - t) * x0, times, codes)
    return float(torch.mean((x1 - x0 - v) ** 2))


def noise_floor(config: DisCoRDConfig) -> float:
    """A lower bound on the t = 0 loss of a velocity-predicting U-Net narrower than the motion: ``(D − w) / D``.

    The U-Net sees each frame of ``x_t`` only through its first 1×1 convolution, ``w`` channels. At t = 0 the
    target ``x1 − x0`` contains all ``D`` dimensions of the frame's noise ``x0 ~ N(0, I)``, independent of
    everything else; ``w`` linear measurements leave at least ``D − w`` of them unpredictable, each with
    variance 1, so the mean squared error per element is at least ``(D − w) / D``.

    An x-predicting network has no such floor (0): it outputs ``x̂1``, and the ``− x_t`` part of the velocity
    ``(x̂1 − x_t) / (1 − t)`` is added outside the network, exactly, in all ``D`` dimensions. The noise does not
    have to pass through the narrow part, so it cannot get stuck there.
    """
    if config.prediction == "x":
        return 0.0
    return max(0.0, (config.feature_dim - config.width) / config.feature_dim)


# ----------------------------------------------------------------------------- training


def discord_trainer(
    model: DisCoRDDecoder,
    tokenizer: Any,
    train_clips: Clips,
    val_clips: Clips | None = None,
    *,
    workdir: str | Path | None = None,
    device: str | None = None,
    progress: bool = True,
    precision: str | None = None,
) -> Trainer:
    """The :class:`~motionlab.train.Trainer` of ``model`` on windows of normalised ``train_clips`` and their frozen
    tokens (not run yet: :func:`train_discord` fits it; ``benchmarks/bench_train.py`` times its steps)."""
    cfg: DisCoRDConfig = model.config
    model.attach(tokenizer)  # checks widths, stride and feature size against the tokenizer
    tokenizer.eval()
    windows = WindowDataset(train_clips, cfg.window)
    if windows.feature_dim != cfg.feature_dim:
        raise ValueError(f"train_clips have {windows.feature_dim} features, the config expects {cfg.feature_dim}")
    val_fn = flow_validation(tokenizer, val_clips, cfg.window, seed=cfg.seed) if val_clips is not None else None
    train = cfg.train_config(
        seed=cfg.seed,
        log_every=max(1, cfg.train_steps // 100),
        val_every=max(1, cfg.train_steps // 10) if val_fn else 0,
        ckpt_every=max(1, cfg.train_steps // 10),  # a killed run resumes from here (Ctrl-C saves where it stops)
    )
    trainer = Trainer(
        model,
        discord_loss_fn,
        token_window_batches(windows, tokenizer, cfg.batch_size),
        train,
        val_fn=val_fn,
        workdir=workdir,
        device=device,
        desc="DisCoRD",
        progress=progress,
        precision=precision,
    )
    compile_for_training([model.unet], "discord", trainer.device)  # the run's --compile setting
    return trainer


def train_discord(
    model: DisCoRDDecoder,
    tokenizer: Any,
    train_clips: Clips,
    val_clips: Clips | None = None,
    *,
    workdir: str | Path | None = None,
    device: str | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Train ``model`` in place on windows of normalised ``train_clips``; leaves it with its EMA weights.

    Returns ``{"history", "steps", "seconds", "cpu_seconds"}``: the trainer's logged rows (``loss``,
    ``lr``, ``grad_norm``, and ``val_loss`` on ``val_clips`` windows if given), wall-clock and CPU time
    (summed over this process's threads) of the run.
    """
    trainer = discord_trainer(
        model, tokenizer, train_clips, val_clips, workdir=workdir, device=device, progress=progress
    )
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        history = trainer.fit()
    finally:
        release_compiled(model)
    seconds, cpu_seconds = time.perf_counter() - wall, time.process_time() - cpu
    if trainer.ema is not None:
        trainer.ema.copy_to(model)  # sample with the averaged weights
    model.eval()
    return {"history": history, "steps": trainer.step, "seconds": seconds, "cpu_seconds": cpu_seconds}


def tokenizer_key(tokenizer: Any, data_key: str) -> str:
    """Which tokenizer the codes come from: the hash of its config and data (its own cache folder name)."""
    config = getattr(tokenizer, "config", None)
    if config is None:
        raise ValueError(f"tokenizer must carry its dataclass .config; got {type(tokenizer).__name__}")
    return artefact_key(config, {"data": data_key})


def _cache_args(dataset: Any, tokenizer: Any, profile: str | None, config: DisCoRDConfig | None):
    for name in ("key", "normalized"):
        if not hasattr(dataset, name):
            raise ValueError(f"dataset must be a MotionDataset (key, normalized()); it lacks {name!r}")
    config = config if config is not None else discord_config(profile, tokenizer=tokenizer)
    if not isinstance(config, DisCoRDConfig):
        raise ValueError(f"config must be a DisCoRDConfig or None, got {type(config).__name__}")
    extra = {"data": dataset.key, "tokenizer": tokenizer_key(tokenizer, dataset.key)}
    return config, extra


def train_or_load_discord(
    dataset: Any,
    tokenizer: Any,
    profile: str | None = None,
    *,
    config: DisCoRDConfig | None = None,
    device: str | None = None,
    progress: bool = True,
) -> DisCoRDDecoder:
    """The cached DisCoRD decoder of ``tokenizer`` on ``dataset`` for ``profile``, trained on first use.

    ``config`` defaults to :func:`~motionlab.flow.discord_config` ``(profile, tokenizer=tokenizer)``.
    Training uses the normalised train split (held-out loss on val); the cache key is the dataset's key,
    the tokenizer's config hash and the whole DisCoRD config. Returns the decoder (EMA weights, eval mode)
    already attached to ``tokenizer``.
    """
    profile = get_profile(profile)
    config, extra = _cache_args(dataset, tokenizer, profile, config)

    def train_fn(model: DisCoRDDecoder, workdir: Path) -> dict[str, Any]:
        return train_discord(
            model,
            tokenizer,
            dataset.normalized("train"),
            dataset.normalized("val"),
            workdir=workdir,
            device=device,
            progress=progress,
        )

    model = train_or_load(MODEL_NAME, config, DisCoRDDecoder, train_fn, profile, extra=extra, device=device)
    return model.attach(tokenizer)


def discord_training_log(
    dataset: Any, tokenizer: Any, profile: str | None = None, *, config: DisCoRDConfig | None = None
) -> dict[str, Any]:
    """What :func:`train_discord` returned when the cached decoder was trained (history, timings)."""
    profile = get_profile(profile)
    config, extra = _cache_args(dataset, tokenizer, profile, config)
    return load_result(MODEL_NAME, config, profile, extra)


__all__ = [
    "MODEL_NAME",
    "code_vectors",
    "discord_trainer",
    "discord_training_log",
    "flow_validation",
    "loss_at_time",
    "noise_floor",
    "token_window_batches",
    "tokenizer_key",
    "train_discord",
    "train_or_load_discord",
]
