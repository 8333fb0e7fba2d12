"""Distribution-level metrics on evaluator embeddings: FID, Diversity and MultiModality."""

from __future__ import annotations

import warnings

import numpy as np
from scipy import linalg

from ._checks import check_embeddings, resolve_rng


def gaussian_stats(embeddings) -> tuple[np.ndarray, np.ndarray]:
    """Mean ``(d,)`` and covariance ``(d, d)`` (``np.cov(rowvar=False)``, unbiased) of ``(N, d)``."""
    x = check_embeddings(embeddings, "embeddings")
    if x.shape[0] < 2:
        raise ValueError(f"embeddings need at least 2 rows for a covariance, got {x.shape[0]}")
    return x.mean(axis=0), np.cov(x, rowvar=False)


def frechet_distance(mu1, sigma1, mu2, sigma2, eps: float = 1e-6) -> float:
    """``||mu1 - mu2||^2 + Tr(S1 + S2 - 2 sqrtm(S1 S2))``, the Frechet distance of two Gaussians.

    ``scipy.linalg.sqrtm`` of a singular product can come back non-finite; then ``eps * I`` is added to
    both covariances and the root retaken. A tiny imaginary part (numerical noise) is dropped; a large one
    is an error.
    """
    mu1, mu2 = np.atleast_1d(mu1).astype(np.float64), np.atleast_1d(mu2).astype(np.float64)
    s1, s2 = np.atleast_2d(sigma1).astype(np.float64), np.atleast_2d(sigma2).astype(np.float64)
    if mu1.shape != mu2.shape or s1.shape != s2.shape or s1.shape != (mu1.size, mu1.size):
        raise ValueError(f"shapes do not match: mu {mu1.shape}/{mu2.shape}, sigma {s1.shape}/{s2.shape}")
    diff = mu1 - mu2
    with warnings.catch_warnings():  # a singular product is handled below, no need to warn
        warnings.simplefilter("ignore", linalg.LinAlgWarning)
        covmean = linalg.sqrtm(s1 @ s2)
        if not np.isfinite(covmean).all():
            offset = np.eye(s1.shape[0]) * eps
            covmean = linalg.sqrtm((s1 + offset) @ (s2 + offset))
    if np.iscomplexobj(covmean):
        if not np.allclose(np.diagonal(covmean).imag, 0, atol=1e-3):
            raise ValueError(f"sqrtm has a large imaginary component {np.abs(covmean.imag).max():.3g}")
        covmean = covmean.real
    return float(diff @ diff + np.trace(s1) + np.trace(s2) - 2.0 * np.trace(covmean))


def fid(embeddings_a, embeddings_b) -> float:
    """FID between two sets of embeddings ``(N, d)`` and ``(M, d)``: Gaussians fitted, then compared."""
    return frechet_distance(*gaussian_stats(embeddings_a), *gaussian_stats(embeddings_b))


def diversity(embeddings, rng: np.random.Generator | int, n_pairs: int = 300) -> float:
    """Mean ``||e[a_k] - e[b_k]||`` over ``n_pairs`` random pairs.

    ``a`` and ``b`` are two independent draws of ``n_pairs`` indices, each without replacement. The
    reference uses 300 pairs, and 100 when ``N <= 300``; we follow it and, below 100 samples, use ``N``.
    """
    x = check_embeddings(embeddings, "embeddings")
    rng = resolve_rng(rng)
    n = x.shape[0]
    if n < 2:
        raise ValueError(f"diversity needs at least 2 embeddings, got {n}")
    times = n_pairs if n > n_pairs else min(100, n)
    a = rng.choice(n, times, replace=False)
    b = rng.choice(n, times, replace=False)
    return float(np.linalg.norm(x[a] - x[b], axis=1).mean())


def multimodality(embeddings, rng: np.random.Generator | int, n_pairs: int = 10) -> float:
    """Mean distance between motions generated for the same text.

    ``embeddings``: ``(n_texts, n_repeats, d)``. Two index sets of ``n_pairs`` repeats are drawn once
    (each without replacement) and used for every text, as in the reference.
    """
    x = check_embeddings(embeddings, "embeddings", ndim=3)
    rng = resolve_rng(rng)
    if x.shape[1] < n_pairs:
        raise ValueError(f"embeddings need at least n_pairs={n_pairs} repeats per text, got {x.shape[1]}")
    a = rng.choice(x.shape[1], n_pairs, replace=False)
    b = rng.choice(x.shape[1], n_pairs, replace=False)
    return float(np.linalg.norm(x[:, a] - x[:, b], axis=-1).mean())
