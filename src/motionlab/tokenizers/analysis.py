"""Looking inside a tokenizer: codebook usage, reconstruction error per clip, residual layers, codebook PCA.

A codebook is healthy when many of its codes are in use. Two numbers say how many, over the token ids
``k_1 .. k_N`` that a dataset is encoded into, with ``p_k`` the fraction of tokens equal to ``k``:

    usage      = |{k : p_k > 0}| / K                 (fraction of codes used at least once)
    perplexity = exp(−Σ_k p_k log p_k)               (1 if one code is used, K if all are used equally)

Reconstruction is judged per clip on joints recovered from the decoded features,

    MPJPE = mean_{t,j} ‖(P̂_tj − P̂_t0) − (P_tj − P_t0)‖₂     (pelvis-aligned, reported in mm)

and on the normalised features themselves (MSE), each as mean ± 95% interval over clips
(:meth:`Reconstruction.errors`); chapter 02's tables of them are in :mod:`motionlab.studies.tokenizer_analysis`.
The 2-D helpers at the end (:func:`gaussian_ring`, :func:`drifting_ring`, :func:`track_codebook`,
:func:`train_toy_quantizer`) watch a bare :class:`QuantizerEMAReset` learn a point cloud, which is how the book
first shows EMA updates and dead-code reset.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from ..estimate import Estimate, mean_ci
from ..metrics import mpjpe
from ..representation import Normalizer, recover_from_ric
from .base import check_ids
from .quantizer import QuantizerEMAReset

# ----------------------------------------------------------------------------------------------
# Codebook usage


@dataclass
class CodebookUsage:
    """Code counts over a set of token ids, one row per (residual) layer."""

    counts: np.ndarray  # (R, K) how often each code was chosen

    @property
    def num_layers(self) -> int:
        return self.counts.shape[0]

    @property
    def codebook_size(self) -> int:
        return self.counts.shape[1]

    @property
    def usage(self) -> np.ndarray:
        """``(R,)`` fraction of codes chosen at least once."""
        return (self.counts > 0).mean(axis=1)

    @property
    def perplexity(self) -> np.ndarray:
        """``(R,)`` exp(entropy) of each layer's code histogram, in [1, K]."""
        p = self.counts / np.maximum(self.counts.sum(axis=1, keepdims=True), 1)
        return np.exp(-(p * np.log(np.where(p > 0, p, 1.0))).sum(axis=1))


def codebook_usage(ids: torch.Tensor | Sequence[torch.Tensor], codebook_size: int) -> CodebookUsage:
    """Count codes in token ids; −1 ("no code", RVQ layers that were dropped) is skipped.

    ``ids`` is a batch, ``(B, N)`` for a plain VQ or ``(B, N, R)`` for an RVQ, or a list of per-clip ids of
    different lengths, ``(N_i,)`` for a VQ or ``(N_i, R)`` for an RVQ.
    """
    if isinstance(codebook_size, bool) or not isinstance(codebook_size, int) or codebook_size < 2:
        raise ValueError(f"codebook_size must be an int >= 2, got {codebook_size!r}")
    if isinstance(ids, (list, tuple)):
        if not ids:
            raise ValueError("ids is an empty list")
        ids = torch.cat([torch.as_tensor(i) for i in ids])[None]  # (1, ΣN_i) or (1, ΣN_i, R)
    ids = torch.as_tensor(ids).cpu()  # counted on the host, wherever the ids were made
    if ids.dim() == 3:
        ids = check_ids(ids, codebook_size, num_layers=ids.shape[-1])
        layers = ids.reshape(-1, ids.shape[-1]).t()  # (R, B·N)
    else:
        layers = check_ids(ids, codebook_size).reshape(1, -1)  # (1, B·N)
    counts = np.stack([torch.bincount(row[row >= 0], minlength=codebook_size).numpy() for row in layers])
    return CodebookUsage(counts.astype(np.int64))


# ----------------------------------------------------------------------------------------------
# Reconstruction of whole clips


@dataclass
class Reconstruction:
    """A tokenizer's round trip of every clip of a split, and its errors per clip."""

    ids: list[torch.Tensor]  # per clip (N_i,) or (N_i, R)
    features: list[np.ndarray]  # per clip (T_i, D) decoded, de-normalised
    joints: list[np.ndarray]  # per clip (T_i, J, 3) recovered from ``features``
    gt_joints: list[np.ndarray]  # per clip (T_i, J, 3) recovered from the (cropped) input
    mpjpe_mm: np.ndarray  # (N,) per-clip MPJPE in millimetres
    feature_mse: np.ndarray  # (N,) per-clip MSE on normalised features

    @property
    def tokens_per_step(self) -> int:
        """Codes per token position (per 4 frames): 1 for a VQ, the residual layers decoded for an RVQ."""
        first = torch.as_tensor(self.ids[0])
        return 1 if first.dim() == 1 else int((first[0] >= 0).sum())

    def errors(self) -> dict[str, Estimate]:
        """``{"mpjpe_mm": …, "feature_mse": …}``: mean ± 95% interval over the clips (Student's t)."""
        return {"mpjpe_mm": mean_ci(self.mpjpe_mm, unit="mm"), "feature_mse": mean_ci(self.feature_mse)}


def _crop(clip: np.ndarray, unit: int) -> np.ndarray:
    return clip[: (len(clip) // unit) * unit]


@torch.no_grad()
def reconstruct_clips(
    model,
    clips: Sequence[np.ndarray],
    normalizer: Normalizer,
    num_layers: int | None = None,
    n_joints: int = 22,
) -> Reconstruction:
    """Encode and decode each normalised clip ``(T_i, D)`` whole (cropped to a multiple of 4 frames).

    ``num_layers`` (RVQ only) decodes with the first ``num_layers`` residual layers. Clips are run one
    at a time, as the references evaluate, so no padding reaches the convolutions.
    """
    if len(clips) == 0:
        raise ValueError("clips is empty")
    if num_layers is not None and getattr(model, "num_layers", 1) == 1:
        raise ValueError("num_layers is only meaningful for a residual (RVQ) tokenizer")
    unit, layers = model.downsample, {} if num_layers is None else {"num_layers": num_layers}
    out = Reconstruction([], [], [], [], np.zeros(len(clips)), np.zeros(len(clips)))
    for i, clip in enumerate(clips):
        clip = np.asarray(clip, dtype=np.float32)
        if clip.ndim != 2 or clip.shape[1] != model.feature_dim or len(clip) < unit:
            raise ValueError(f"clips[{i}] must be (T >= {unit}, {model.feature_dim}), got {clip.shape}")
        x = torch.from_numpy(_crop(clip, unit))[None]  # (1, T, D)
        ids = model.encode(x, **layers)  # (1, T/4) or (1, T/4, R)
        recon = model.decode(ids, **layers)[0].cpu().numpy()  # (T, D) normalised
        features = normalizer.denormalize(recon)
        joints = np.asarray(recover_from_ric(features, n_joints))
        gt = np.asarray(recover_from_ric(normalizer.denormalize(x[0].numpy()), n_joints))
        out.ids.append(ids[0].cpu())
        out.features.append(features)
        out.joints.append(joints)
        out.gt_joints.append(gt)
        out.mpjpe_mm[i] = 1000.0 * mpjpe(joints, gt)
        out.feature_mse[i] = float(np.mean((recon - x[0].numpy()) ** 2))
    return out


# ----------------------------------------------------------------------------------------------
# Codebook geometry


def codebook_pca(codes: torch.Tensor | np.ndarray, n_components: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Project code vectors ``(K, C)`` onto their top principal axes (as in M2D2M's codebook figure).

    Returns ``coords (K, n_components)`` and the fraction of variance each axis explains. Each axis'
    sign is fixed so that its largest loading is positive, which makes the picture deterministic.
    """
    c = codes.detach().cpu().numpy() if isinstance(codes, torch.Tensor) else np.asarray(codes)
    if c.ndim != 2 or c.shape[0] < 2:
        raise ValueError(f"codes must have shape (K >= 2, C), got {c.shape}")
    if not 1 <= n_components <= min(c.shape):
        raise ValueError(f"n_components must be in [1, {min(c.shape)}], got {n_components}")
    centred = c.astype(np.float64) - c.mean(axis=0)
    _, s, vt = np.linalg.svd(centred, full_matrices=False)  # rows of vt: principal axes
    axes = vt[:n_components]
    axes *= np.sign(axes[np.arange(n_components), np.abs(axes).argmax(axis=1)])[:, None]
    explained = s**2 / max(float((s**2).sum()), 1e-300)
    return centred @ axes.T, explained[:n_components]


# ----------------------------------------------------------------------------------------------
# A quantizer on 2-D points


def gaussian_ring(
    n: int, modes: int = 8, radius: float = 1.0, std: float = 0.1, *, generator: torch.Generator
) -> torch.Tensor:
    """``n`` points ``(n, 2)`` from ``modes`` equal Gaussian blobs spaced evenly on a circle."""
    if n < 1 or modes < 1 or radius < 0 or std < 0:
        raise ValueError(f"need n >= 1, modes >= 1, radius >= 0, std >= 0; got {n}, {modes}, {radius}, {std}")
    mode = torch.randint(modes, (n,), generator=generator)
    angle = 2 * torch.pi * mode.float() / modes
    centres = radius * torch.stack([torch.cos(angle), torch.sin(angle)], dim=1)  # (n, 2)
    return centres + std * torch.randn(n, 2, generator=generator)


@dataclass
class CodebookTrace:
    """What a quantizer did during :func:`track_codebook`."""

    steps: np.ndarray  # (S,) steps at which the codebook was saved (after that step's update)
    codebooks: np.ndarray  # (S, K, C)
    perplexity: np.ndarray  # (steps,) of each training batch
    usage: np.ndarray  # (steps,) fraction of codes the batch used
    distortion: np.ndarray  # (steps,) mean squared distance of the batch to its codes (the commitment MSE)

    def history(self) -> list[dict[str, float]]:
        """The per-batch numbers as training-log rows ``{"step", "perplexity", "usage", "distortion"}`` (step
        0 is the first batch), for :func:`motionlab.viz.plot_history`."""
        return [
            {"step": i, "perplexity": float(p), "usage": float(u), "distortion": float(d)}
            for i, (p, u, d) in enumerate(zip(self.perplexity, self.usage, self.distortion, strict=True))
        ]


def track_codebook(
    quantizer: QuantizerEMAReset,
    batch_fn: Callable[[int, torch.Generator], torch.Tensor],
    steps: int,
    generator: torch.Generator,
    every: int = 10,
) -> CodebookTrace:
    """Run ``steps`` training-mode forwards of ``quantizer`` on ``batch_fn(step, generator) (N, C)``.

    Each forward assigns the batch to its nearest codes and updates the codebook (EMA, then reset of
    dead codes), exactly as inside a VQ-VAE; the encoder is replaced by ``batch_fn``. The codebook is
    saved before the first step and after every ``every`` steps.
    """
    if steps < 1 or every < 1:
        raise ValueError(f"steps and every must be >= 1, got {steps} and {every}")
    quantizer.train()
    saved_steps, codebooks = [0], [quantizer.codebook.detach().clone().cpu().numpy()]
    perplexity, usage, distortion = np.zeros(steps), np.zeros(steps), np.zeros(steps)
    for step in range(steps):
        x = batch_fn(step, generator)
        if x.dim() != 2 or x.shape[1] != quantizer.code_dim:
            raise ValueError(f"batch_fn must return (N, {quantizer.code_dim}), got {tuple(x.shape)}")
        out = quantizer(x.to(quantizer.codebook.device), generator)
        perplexity[step], usage[step], distortion[step] = (
            out.perplexity.item(),
            out.usage.item(),
            out.commit_loss.item(),
        )
        if (step + 1) % every == 0 or step + 1 == steps:
            saved_steps.append(step + 1)
            codebooks.append(quantizer.codebook.detach().clone().cpu().numpy())
    quantizer.eval()
    return CodebookTrace(np.array(saved_steps), np.stack(codebooks), perplexity, usage, distortion)


def drifting_ring(step: int, generator: torch.Generator, n: int = 256, spread_steps: int = 100) -> torch.Tensor:
    """A stand-in for the outputs of an encoder being trained: ``n`` points of :func:`gaussian_ring`, bunched near
    the origin at first (scale 0.05) and spread out to the unit ring after ``spread_steps`` steps."""
    if spread_steps < 1:
        raise ValueError(f"spread_steps must be >= 1, got {spread_steps}")
    return min(1.0, 0.05 + step / spread_steps) * gaussian_ring(n, generator=generator)


def train_toy_quantizer(
    decay: float = 0.9,
    reset: bool = True,
    codebook_size: int = 32,
    steps: int = 400,
    seed: int = 0,
    every: int = 10,
) -> tuple[QuantizerEMAReset, CodebookTrace]:
    """A 2-D :class:`QuantizerEMAReset` trained on :func:`drifting_ring` for ``steps`` batches (EMA ``decay``, dead
    codes reset or not), seeded by ``seed``; returns the quantizer and its :class:`CodebookTrace`."""
    # reset_threshold=0: no count is ever below the threshold, so nothing is reset
    quantizer = QuantizerEMAReset(codebook_size, 2, decay=decay, reset_threshold=1.0 if reset else 0.0, seed=seed)
    trace = track_codebook(quantizer, drifting_ring, steps, torch.Generator().manual_seed(seed), every=every)
    return quantizer, trace


__all__ = [
    "CodebookTrace",
    "CodebookUsage",
    "Reconstruction",
    "codebook_pca",
    "codebook_usage",
    "drifting_ring",
    "gaussian_ring",
    "reconstruct_clips",
    "track_codebook",
    "train_toy_quantizer",
]
