"""Training a tokenizer on motion windows, and the train-once cache the chapters load from."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from ..train import Trainer, WindowDataset, load_trained, train_or_load
from ..train.compiling import compile_for_training, release_compiled
from .config import RVQConfig, VQConfig, rvq_config, vq_config
from .losses import tokenizer_loss
from .models import RVQVAE, VQVAE, ConvTokenizer, build_tokenizer

Clips = Sequence[np.ndarray]
KINDS = {"vq": vq_config, "rvq": rvq_config}


def tokenizer_loss_fn(model: ConvTokenizer, batch: torch.Tensor, generator: torch.Generator) -> dict:
    """The :class:`~motionlab.train.Trainer` loss: reconstruction + ric + commitment, plus codebook stats (on the
    model's device; ``batch`` is moved there)."""
    c = model.config
    batch = batch.to(model.device)
    out = model(batch, generator=generator)
    terms = tokenizer_loss(out.recon, batch, out.commit_loss, c.n_joints, c.ric_weight, c.commit_weight)
    terms["perplexity"] = out.perplexity.detach().float().mean()  # mean over residual layers for RVQ
    return terms


def window_validation(model: ConvTokenizer, clips: Clips, n_windows: int = 256, seed: int = 0) -> Callable:
    """A ``val_fn`` measuring reconstruction (argmin codes, no updates) on a fixed set of held-out windows."""
    data = WindowDataset(clips, model.config.window)
    windows = data.sample(min(n_windows, len(data)), torch.Generator().manual_seed(seed))

    def val_fn(m: ConvTokenizer) -> dict[str, float]:
        x = windows.to(m.device)
        recon = m.decode(m.encode(x))
        return {"recon": float(F.smooth_l1_loss(recon, x)), "mse": float(F.mse_loss(recon, x))}

    return val_fn


def tokenizer_trainer(
    model: ConvTokenizer,
    train_clips: Clips,
    val_clips: Clips | None = None,
    *,
    workdir: str | Path | None = None,
    device: str | None = None,
    progress: bool = True,
    precision: str | None = None,
) -> Trainer:
    """The :class:`~motionlab.train.Trainer` of ``model`` on random windows of normalised ``train_clips`` (not run
    yet: :func:`train_tokenizer` fits it; ``benchmarks/bench_train.py`` times its steps). ``precision``: the run's."""
    c = model.config
    data = WindowDataset(train_clips, c.window)
    if data.feature_dim != c.feature_dim:
        raise ValueError(f"train_clips have {data.feature_dim} features, the config expects {c.feature_dim}")
    val_fn = window_validation(model, val_clips) if val_clips is not None else None
    trainer = Trainer(
        model,
        tokenizer_loss_fn,
        data.batches(c.batch_size),
        c.train,
        val_fn=val_fn,
        workdir=workdir,
        device=device,
        desc=type(model).__name__,
        progress=progress,
        precision=precision,
    )
    # the convolutions only: the quantizer's codebook updates run in place, step by step, in fp32
    compile_for_training([model.encoder, model.decoder], "tokenizer", trainer.device)
    return trainer


def train_tokenizer(
    model: ConvTokenizer,
    train_clips: Clips,
    val_clips: Clips | None = None,
    *,
    workdir: str | Path | None = None,
    device: str | None = None,
    progress: bool = True,
) -> list[dict[str, float]]:
    """Train ``model`` on random windows of normalised ``train_clips``; returns the logged history."""
    trainer = tokenizer_trainer(model, train_clips, val_clips, workdir=workdir, device=device, progress=progress)
    try:
        history = trainer.fit()
    finally:
        release_compiled(model)
    if trainer.val_fn is not None and not (history and any(k.startswith("val_") for k in history[-1])):
        history.append({"step": trainer.step, **trainer.validate()})
    model.eval()
    return history


def _config_for(kind: str, profile: str | None, config: VQConfig | None) -> VQConfig:
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {sorted(KINDS)}, got {kind!r}")
    if config is None:
        return KINDS[kind](profile)
    expected = RVQConfig if kind == "rvq" else VQConfig
    if type(config) is not expected:
        raise ValueError(f"kind {kind!r} needs a {expected.__name__}, got {type(config).__name__}")
    return config


def train_or_load_tokenizer(
    kind: str,
    train_clips: Clips | Callable[[], Clips],
    profile: str | None = None,
    *,
    val_clips: Clips | Callable[[], Clips] | None = None,
    config: VQConfig | None = None,
    name: str | None = None,
    data_key: str = "",
    device: str | None = None,
    progress: bool = True,
) -> VQVAE | RVQVAE:
    """The cached ``"vq"`` or ``"rvq"`` tokenizer for ``profile``, trained on first use.

    ``train_clips`` (and ``val_clips``) may be callables so the data is only loaded when training is
    needed; ``data_key`` names the data (it enters the cache hash, so other data means another model).
    """
    config = _config_for(kind, profile, config)

    def train_fn(model: ConvTokenizer, workdir: Path) -> list[dict[str, float]]:
        clips = train_clips() if callable(train_clips) else train_clips
        val = val_clips() if callable(val_clips) else val_clips
        return train_tokenizer(model, clips, val, workdir=workdir, device=device, progress=progress)

    return train_or_load(
        name or kind, config, build_tokenizer, train_fn, profile, extra={"data": data_key}, device=device
    )


def load_tokenizer(
    kind: str,
    profile: str | None = None,
    *,
    config: VQConfig | None = None,
    name: str | None = None,
    data_key: str = "",
    device: str | None = None,
) -> VQVAE | RVQVAE:
    """A tokenizer trained earlier by :func:`train_or_load_tokenizer` (``FileNotFoundError`` if there is none)."""
    config = _config_for(kind, profile, config)
    return load_trained(name or kind, config, build_tokenizer, profile, extra={"data": data_key}, device=device)


def tokenizer_for_dataset(
    kind: str,
    dataset,
    profile: str | None = None,
    *,
    seed: int = 0,
    device: str | None = None,
    progress: bool = True,
) -> VQVAE | RVQVAE:
    """The book's standard ``"vq"``/``"rvq"`` tokenizer of a :class:`~motionlab.data.MotionDataset`.

    Trained on first use on the normalised train split (validated on val) with the profile's config sized
    to the dataset's features (263 for HumanML3D, 251 for KIT-ML), cached under the dataset's key: every
    chapter and the command line that asks for it gets the same model. ``seed`` is the training seed (weights,
    codebook draws and batch order): seed 0 is the book's tokenizer, another seed a replicate (another cache entry).
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {sorted(KINDS)}, got {kind!r}")
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    features = {"feature_dim": dataset.kind.feature_dim, "n_joints": dataset.skeleton.n_joints}
    config = KINDS[kind](profile, **features)
    config = replace(config, seed=seed, train=replace(config.train, seed=seed))
    return train_or_load_tokenizer(
        kind,
        lambda: dataset.normalized("train"),
        profile,
        val_clips=lambda: dataset.normalized("val"),
        config=config,
        data_key=dataset.key,
        device=device,
        progress=progress,
    )
