"""Distribution-level metrics on evaluator embeddings: FID, Diversity and MultiModality."""

from __future__ import annotations

import numpy as np

from ._checks import check_embeddings, resolve_rng


def gaussian_stats(embeddings) -> tuple[np.ndarray, np.ndarray]:
    """Mean ``(d,)`` and covariance ``(d, d)`` (``np.cov(rowvar=False)``, unbiased) of ``(N, d)``."""
    x = check_embeddings(embeddings, "embeddings")
    if x.shape[0] < 2:
        raise ValueError(f"embeddings need at least 2 rows for a covariance, got {x.shape[0]}")
    return x.mean(axis=0), np.cov(x, rowvar=False)


def _check_symmetric(sigma: np.ndarray, name: str) -> None:
    if not np.allclose(sigma, sigma.T, rtol=1e-8, atol=1e-12):
        raise ValueError(f"{name} must be a symmetric covariance matrix")


def _check_psd(eigenvalues: np.ndarray, name: str) -> None:
    """Rounding leaves tiny negative eigenvalues (they count as 0); a larger one means no covariance."""
    if eigenvalues.min(initial=0.0) < -1e-6 * max(np.abs(eigenvalues).max(initial=0.0), 1e-300):
        raise ValueError(f"{name} is not positive semi-definite (eigenvalue {eigenvalues.min():.3g})")


def frechet_distance(mu1, sigma1, mu2, sigma2) -> float:
    """``||mu1 - mu2||^2 + Tr(S1 + S2 - 2 sqrtm(S1 S2))``, the Frechet distance of two Gaussians.

    ``Tr sqrtm(S1 S2)`` is the sum of the square roots of the eigenvalues of ``S1 S2``, which has the same
    eigenvalues as the symmetric ``R S2 R`` with ``R = S1^(1/2)``. Two symmetric eigendecompositions give it:
    about 3x faster than ``scipy.linalg.sqrtm`` at d = 512 (the official evaluators' route; the two agree
    to about 1e-7 relative), and a singular covariance (fewer samples than dimensions) needs no special case.
    A negative direction of S2 shows as a negative eigenvalue of ``R S2 R``.
    """
    mu1, mu2 = np.atleast_1d(mu1).astype(np.float64), np.atleast_1d(mu2).astype(np.float64)
    s1, s2 = np.atleast_2d(sigma1).astype(np.float64), np.atleast_2d(sigma2).astype(np.float64)
    if mu1.shape != mu2.shape or s1.shape != s2.shape or s1.shape != (mu1.size, mu1.size):
        raise ValueError(f"shapes do not match: mu {mu1.shape}/{mu2.shape}, sigma {s1.shape}/{s2.shape}")
    if not (np.isfinite(mu1).all() and np.isfinite(mu2).all() and np.isfinite(s1).all() and np.isfinite(s2).all()):
        raise ValueError("means and covariances must be finite")
    _check_symmetric(s1, "sigma1")
    _check_symmetric(s2, "sigma2")
    w, v = np.linalg.eigh(s1)
    _check_psd(w, "sigma1")
    root1 = (v * np.sqrt(np.clip(w, 0.0, None))) @ v.T  # S1^(1/2)
    product = root1 @ s2 @ root1
    eigenvalues = np.linalg.eigvalsh((product + product.T) / 2.0)  # symmetric up to rounding
    _check_psd(eigenvalues, "sigma2")
    diff = mu1 - mu2
    return float(diff @ diff + np.trace(s1) + np.trace(s2) - 2.0 * np.sqrt(np.clip(eigenvalues, 0.0, None)).sum())


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
