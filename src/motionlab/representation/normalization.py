"""Mean/Std normalisation of HumanML3D features, with HumanML3D's group-averaged standard deviation."""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from .features import feature_slices
from .skeleton import Skeleton, skeleton_for_feature_dim


def group_std(features: np.ndarray, skeleton: str | Skeleton | None = None) -> np.ndarray:
    """Per-dimension std replaced by the mean std of its feature group (as ``cal_mean_variance`` does).

    Averaging within a group keeps, e.g., all 63 ric dimensions on one scale, so a joint that barely
    moves in the data is not blown up by a tiny std.
    """
    features = np.asarray(features, dtype=np.float64)
    sk = skeleton if skeleton is not None else skeleton_for_feature_dim(features.shape[-1])
    std = features.reshape(-1, features.shape[-1]).std(axis=0)
    for s in feature_slices(sk).values():
        std[s] = std[s].mean()
    return std


@dataclass
class Normalizer:
    """z-normalisation ``(x - mean) / std`` for features; works on NumPy arrays and torch tensors."""

    mean: np.ndarray
    std: np.ndarray

    def __post_init__(self):
        self.mean = np.asarray(self.mean, dtype=np.float32)
        self.std = np.asarray(self.std, dtype=np.float32)
        if self.mean.shape != self.std.shape or self.mean.ndim != 1:
            raise ValueError(f"mean and std must be 1-D of equal size, got {self.mean.shape} and {self.std.shape}")
        if not (np.isfinite(self.mean).all() and np.isfinite(self.std).all()) or (self.std <= 0).any():
            raise ValueError("mean/std must be finite and std strictly positive")

    @property
    def dim(self) -> int:
        return self.mean.shape[0]

    @classmethod
    def fit(cls, clips: Iterable[np.ndarray], skeleton: str | Skeleton | None = None, eps: float = 1e-8):
        """Mean and group-averaged std over all frames of ``clips`` (each ``(T, D)``)."""
        data = np.concatenate([np.asarray(c, dtype=np.float64) for c in clips], axis=0)
        if data.ndim != 2:
            raise ValueError(f"clips must be (T, D) arrays, got concatenated shape {data.shape}")
        return cls(data.mean(axis=0), np.maximum(group_std(data, skeleton), eps))

    @classmethod
    def load(cls, folder: str | os.PathLike) -> Normalizer:
        """Read ``Mean.npy`` and ``Std.npy`` from a dataset folder."""
        folder = Path(folder)
        missing = [n for n in ("Mean.npy", "Std.npy") if not (folder / n).is_file()]
        if missing:
            raise FileNotFoundError(f"{folder} is missing {', '.join(missing)}")
        arrays = []
        for name in ("Mean.npy", "Std.npy"):
            try:
                arrays.append(np.load(folder / name, allow_pickle=False))
            except (OSError, ValueError, EOFError) as err:  # EOFError: an empty file
                raise ValueError(f"{folder / name} cannot be read as a .npy array ({err})") from None
        return cls(*arrays)

    def save(self, folder: str | os.PathLike) -> None:
        """Write ``Mean.npy`` and ``Std.npy`` (float32, as HumanML3D ships them)."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        for name, arr in (("Mean.npy", self.mean), ("Std.npy", self.std)):
            tmp = folder / f".{name}.tmp.npy"
            np.save(tmp, arr.astype(np.float32))
            os.replace(tmp, folder / name)

    def _stats_like(self, x):
        if isinstance(x, torch.Tensor):
            return (
                torch.as_tensor(self.mean, dtype=x.dtype, device=x.device),
                torch.as_tensor(self.std, dtype=x.dtype, device=x.device),
            )
        return self.mean.astype(np.asarray(x).dtype, copy=False), self.std.astype(np.asarray(x).dtype, copy=False)

    def _check(self, x):
        if x.shape[-1] != self.dim:
            raise ValueError(f"expected features with last dimension {self.dim}, got shape {tuple(x.shape)}")

    def normalize(self, x):
        self._check(x)
        mean, std = self._stats_like(x)
        return (x - mean) / std

    def denormalize(self, x):
        self._check(x)
        mean, std = self._stats_like(x)
        return x * std + mean
