"""Input validation shared by the metric entry points (each public function checks once, at the boundary)."""

from __future__ import annotations

import numpy as np
import torch


def as_float_array(x, name: str) -> np.ndarray:
    """``x`` (NumPy array, torch tensor or nested list) as a float64 array, rejecting NaN/inf."""
    if isinstance(x, torch.Tensor):
        x = x.detach().cpu().double().numpy()
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must be a numeric array, got {type(x).__name__}") from err
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or inf values")
    return arr


def check_joints(x, name: str, n_joints: int | None = None, min_frames: int = 4) -> np.ndarray:
    """One clip of joint positions ``(T, J, 3)`` with at least ``min_frames`` frames."""
    arr = as_float_array(x, name)
    want = f"(T, {n_joints if n_joints is not None else 'J'}, 3)"
    if arr.ndim != 3 or arr.shape[-1] != 3 or (n_joints is not None and arr.shape[1] != n_joints):
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if arr.shape[0] < min_frames:
        raise ValueError(f"{name} needs at least {min_frames} frames (a third difference), got {arr.shape[0]}")
    return arr


def check_embeddings(x, name: str, ndim: int = 2) -> np.ndarray:
    """Embeddings ``(N, d)`` (or ``(n_texts, n_repeats, d)`` with ``ndim=3``)."""
    arr = as_float_array(x, name)
    if arr.ndim != ndim:
        shape = "(N, d)" if ndim == 2 else "(n_texts, n_repeats, d)"
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    return arr


def resolve_rng(rng: np.random.Generator | int | None) -> np.random.Generator:
    """An explicit generator, or a fresh one from an integer seed; ``None`` is refused (no hidden state)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, (int, np.integer)):
        return np.random.default_rng(int(rng))
    raise ValueError(f"rng must be a numpy Generator or an integer seed, got {type(rng).__name__}")
