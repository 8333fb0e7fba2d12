"""The contract between motion tokenizers and everything that consumes tokens.

A tokenizer turns normalised motion ``(B, T, D)`` into token ids on a grid 4× coarser in time, and back.
The token generators (discrete diffusion, Chapter M2D2M) only see ids and the codebook; the DisCoRD
decoder only sees the code vectors from :meth:`Tokenizer.embed`. Both work with either tokenizer:

===================  ==========================  =====================================
                     ``VQVAE`` (T2M-GPT, M2D2M)  ``RVQVAE`` (MoMask, used by DisCoRD)
===================  ==========================  =====================================
``encode`` → ids     ``(B, T/4)``                ``(B, T/4, R)``
``embed(ids)``       code vectors                sum of the R layers' code vectors
===================  ==========================  =====================================
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
import torch

from ..checks import values_checked


@runtime_checkable
class Tokenizer(Protocol):
    """What the rest of motionlab may rely on. Implemented by ``VQVAE`` and ``RVQVAE``."""

    codebook_size: int  # K: codes per codebook
    code_dim: int  # C: size of a code vector
    downsample: int  # frames per token (4)
    num_layers: int  # residual layers R (1 for plain VQ)
    feature_dim: int  # D: motion features per frame (263 for HumanML3D)

    def encode(self, motion: torch.Tensor) -> torch.Tensor:
        """Normalised motion ``(B, T, D)``, T a multiple of 4 → ids ``(B, T/4)`` or ``(B, T/4, R)``."""
        ...

    def embed(self, ids: torch.Tensor) -> torch.Tensor:
        """Ids → code vectors ``(B, T/4, code_dim)`` (summed over residual layers)."""
        ...

    def decode(self, ids: torch.Tensor) -> torch.Tensor:
        """Ids → normalised motion ``(B, T, D)``."""
        ...

    def codebook(self, layer: int = 0) -> torch.Tensor:
        """The code vectors of one layer, ``(K, code_dim)``."""
        ...


def check_motion(motion, feature_dim: int, downsample: int = 4, name: str = "motion") -> torch.Tensor:
    """Validate ``(B, T, D)`` motion for a tokenizer and return it as a float32 tensor.

    Float64 (a NumPy default) and integer input are converted; NaN or inf is rejected, because the nearest
    code of a NaN latent is silently code 0."""
    if isinstance(motion, np.ndarray):
        motion = torch.from_numpy(motion)
    if not isinstance(motion, torch.Tensor):
        raise ValueError(f"{name} must be a tensor of shape (B, T, {feature_dim}), got {type(motion).__name__}")
    if motion.dim() != 3 or motion.shape[-1] != feature_dim:
        raise ValueError(f"{name} must have shape (B, T, {feature_dim}), got {tuple(motion.shape)}")
    t = motion.shape[1]
    if t == 0 or t % downsample:
        raise ValueError(f"{name} length T={t} must be a positive multiple of {downsample}; crop it first")
    if motion.dtype == torch.bool or motion.is_complex():
        raise ValueError(f"{name} must hold real numbers, got dtype {motion.dtype}")
    if motion.dtype != torch.float32:
        motion = motion.float()  # the networks' weights are float32
    if values_checked(motion) and not torch.isfinite(motion).all():
        raise ValueError(f"{name} contains NaN or inf values")
    return motion


def check_ids(ids, codebook_size: int, num_layers: int | None = None, name: str = "ids") -> torch.Tensor:
    """Validate token ids: ``(B, N)`` in [0, K) when ``num_layers`` is None (plain VQ), else ``(B, N, R')``
    with 1 ≤ R' ≤ num_layers and values in [−1, K) (−1 = no code)."""
    if isinstance(ids, np.ndarray):
        ids = torch.from_numpy(ids)
    if not isinstance(ids, torch.Tensor) or ids.is_floating_point() or ids.dtype == torch.bool:
        raise ValueError(f"{name} must be an integer tensor, got {getattr(ids, 'dtype', type(ids).__name__)}")
    if num_layers is None:
        if ids.dim() != 2:
            raise ValueError(f"{name} must have shape (B, N) for a single-codebook VQ, got {tuple(ids.shape)}")
        low = 0
    else:
        if ids.dim() != 3 or not 1 <= ids.shape[-1] <= num_layers:
            raise ValueError(f"{name} must have shape (B, N, R) with 1 <= R <= {num_layers}, got {tuple(ids.shape)}")
        low = -1
    if ids.shape[0] == 0 or ids.shape[1] == 0:
        raise ValueError(f"{name} must hold at least one token per sequence, got shape {tuple(ids.shape)}")
    if ids.numel() and values_checked(ids) and (int(ids.min()) < low or int(ids.max()) >= codebook_size):
        raise ValueError(
            f"{name} must lie in [{low}, {codebook_size}), got values in [{int(ids.min())}, {int(ids.max())}]"
        )
    return ids.long()
