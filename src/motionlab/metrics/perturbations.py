"""Controlled damage to real motion, for testing what a metric notices (DisCoRD Fig. 4 and its mirror image).

Two failure modes of a motion decoder, made on purpose:

* **frame-wise noise** -- what a token decoder adds: i.i.d. Gaussian noise on every frame of the
  *normalised* features, the space a decoder writes. In raw units that is ``x + sigma * std * eps``,
  ``eps ~ N(0, I)``, so every feature moves by ``sigma`` of its own spread;
* **over-smoothing** -- under-reconstruction: a Gaussian filter of ``sigma_frames`` frames along time.
  The filter is linear and the normalisation is a per-dimension affine map, so smoothing raw or
  normalised features gives the same motion.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..representation import Normalizer
from ._checks import as_float_array


def _clips(features: Sequence, name: str) -> list[np.ndarray]:
    if isinstance(features, np.ndarray) and features.ndim == 2:
        raise ValueError(f"{name} must be a list of (T, D) clips, not one (T, D) array")
    if len(features) == 0:
        raise ValueError(f"{name} is empty")
    out = [as_float_array(f, f"{name}[{i}]") for i, f in enumerate(features)]
    for i, a in enumerate(out):
        if a.ndim != 2:
            raise ValueError(f"{name}[{i}] must have shape (T, D), got {a.shape}")
    return out


def _check_add_frame_noise_inputs(
    features: Sequence, sigma: float, normalizer: Normalizer, rng: np.random.Generator
) -> list[np.ndarray]:
    """Reject a bad ``sigma`` or ``rng`` and clips unlike the normalizer; return the clips as float arrays."""
    if not np.isfinite(sigma) or sigma < 0:
        raise ValueError(f"sigma must be a finite non-negative number, got {sigma}")
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy Generator, got {type(rng).__name__}")
    clips = _clips(features, "features")
    std = np.asarray(normalizer.std, dtype=np.float64)
    if any(c.shape[1] != std.shape[0] for c in clips):
        raise ValueError(f"features must have {std.shape[0]} dims like the normalizer")
    return clips


def add_frame_noise(
    features: Sequence, sigma: float, normalizer: Normalizer, rng: np.random.Generator
) -> list[np.ndarray]:
    """Raw clips ``(T_i, D)`` plus i.i.d. noise of ``sigma`` in normalised units: ``x + sigma * std * eps``."""
    clips = _check_add_frame_noise_inputs(features, sigma, normalizer, rng)
    std = np.asarray(normalizer.std, dtype=np.float64)
    return [c + sigma * std * rng.standard_normal(c.shape) for c in clips]


def smooth_in_time(features: Sequence, sigma_frames: float) -> list[np.ndarray]:
    """Each clip ``(T_i, D)`` filtered along time by a Gaussian of ``sigma_frames`` frames (edges: nearest)."""
    if not np.isfinite(sigma_frames) or sigma_frames < 0:
        raise ValueError(f"sigma_frames must be a finite non-negative number, got {sigma_frames}")
    clips = _clips(features, "features")
    if sigma_frames == 0:
        return [c.copy() for c in clips]
    return [gaussian_filter1d(c, sigma_frames, axis=0, mode="nearest") for c in clips]
