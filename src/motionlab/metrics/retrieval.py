"""Text-motion retrieval metrics: R-precision (top-1/2/3) and MM-Dist, over batches of 32."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import check_embeddings, resolve_rng


def euclidean_distance_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``D[i, k] = ||a_i - b_k||`` for ``a (N, d)``, ``b (M, d)`` -> ``(N, M)``."""
    return np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1)


@dataclass
class RetrievalScores:
    r_precision: np.ndarray  # (top_k,): cumulative, [top-1, top-2, top-3]
    mm_dist: float
    n_samples: int  # samples used (a trailing incomplete batch is dropped)


def retrieval_metrics(
    text_emb, motion_emb, batch_size: int = 32, top_k: int = 3, rng: np.random.Generator | int | None = None
) -> RetrievalScores:
    """R-precision and MM-Dist of aligned pairs ``text_emb[i] <-> motion_emb[i]`` (both ``(N, d)``).

    The pairs are cut into consecutive batches of ``batch_size`` (after a random permutation when ``rng``
    is given -- the reference's test loader shuffles); an incomplete last batch is dropped (its
    ``drop_last=True``). Inside a batch, each text ranks the batch's motions by Euclidean distance:

    * top-k counts the texts whose own motion is among the k nearest (so top-1 <= top-2 <= top-3);
    * MM-Dist is the mean distance between a text and its own motion (the distance matrix's trace).

    Both are summed over batches and divided by the number of samples used. With random embeddings
    top-k is about ``k / batch_size``.
    """
    text = check_embeddings(text_emb, "text_emb")
    motion = check_embeddings(motion_emb, "motion_emb")
    if text.shape != motion.shape:
        raise ValueError(f"text_emb {text.shape} and motion_emb {motion.shape} must have the same shape")
    if not 1 <= top_k <= batch_size:
        raise ValueError(f"top_k must be in [1, batch_size={batch_size}], got {top_k}")
    n_batches = text.shape[0] // batch_size
    if n_batches == 0:
        raise ValueError(f"need at least batch_size={batch_size} pairs, got {text.shape[0]}")
    order = np.arange(text.shape[0]) if rng is None else resolve_rng(rng).permutation(text.shape[0])
    hits = np.zeros(top_k)
    match = 0.0
    for b in range(n_batches):
        idx = order[b * batch_size : (b + 1) * batch_size]
        dist = euclidean_distance_matrix(text[idx], motion[idx])  # (B, B)
        match += np.trace(dist)
        # rank of the true motion = number of motions strictly closer (ties go to the true motion;
        # the reference argsorts, which breaks exact ties arbitrarily)
        rank = (dist < np.diagonal(dist)[:, None]).sum(axis=1)  # (B,)
        hits += (rank[:, None] < np.arange(1, top_k + 1)[None, :]).sum(axis=0)
    n = n_batches * batch_size
    return RetrievalScores(hits / n, float(match / n), n)


def r_precision(text_emb, motion_emb, batch_size: int = 32, top_k: int = 3, rng=None) -> np.ndarray:
    """Cumulative top-1..top-k retrieval accuracy ``(top_k,)``; see :func:`retrieval_metrics`."""
    return retrieval_metrics(text_emb, motion_emb, batch_size, top_k, rng).r_precision


def mm_dist(text_emb, motion_emb, batch_size: int = 32, rng=None) -> float:
    """Mean text-to-own-motion distance (the "matching score"); see :func:`retrieval_metrics`."""
    return retrieval_metrics(text_emb, motion_emb, batch_size, 1, rng).mm_dist
