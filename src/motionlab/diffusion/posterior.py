"""Forward marginals and posteriors of discrete diffusion for any dense transition matrices, in log space.

With row = from, column = to (see :mod:`motionlab.diffusion.transitions`)::

    q(x_t | x_0)                = Q̄_t[x_0, x_t]
    q(x_{t-1} | x_t, x_0)       = Q_t[x_{t-1}, x_t] · Q̄_{t-1}[x_0, x_{t-1}] / Q̄_t[x_0, x_t]         (Bayes)
    p_θ(x_{t-1} | x_t)          = Σ_{x_0} q(x_{t-1} | x_t, x_0) · p_θ(x_0 | x_t)                    (Eq. 4)
                                = Q_t[x_{t-1}, x_t] · Σ_{x_0} (p_θ(x_0 | x_t) / Q̄_t[x_0, x_t]) · Q̄_{t-1}[x_0, x_{t-1}]

The last line is one (B·L, K) × (K, K+1) product per step, whatever Q is; it needs no symmetry (VQ-Diffusion's
closed form does) and so also serves M2D2M's dynamic matrices. Nothing here assumes one step either: pass
``step = q(x_t | x_s)`` and ``cum_prev = Q̄_s`` to jump from t to any s < t (fast sampling).

Matrices are passed either shared, (K+1, K+1), or one per sample, (B, K+1, K+1). Log-probabilities are
floored at :data:`LOG_FLOOR` (e^-70 ≈ 4e-31, far below float32 resolution), as VQ-Diffusion does, so that
KL terms never meet ``0 · log 0``.
"""

from __future__ import annotations

import math

import torch
from torch import Tensor

from motionlab.checks import values_checked
from motionlab.precision import in_fp32

LOG_FLOOR = -70.0
_P_FLOOR = math.exp(LOG_FLOOR)


def safe_log(p: Tensor) -> Tensor:
    """log p with p floored at e^-70."""
    return torch.log(p.clamp_min(_P_FLOOR))


def _check_matrix(M: Tensor, batch: int, name: str) -> Tensor:
    if M.ndim == 2:
        if M.shape[0] != M.shape[1]:
            raise ValueError(f"{name} must be (K+1, K+1) or (B, K+1, K+1), got {tuple(M.shape)}")
        return M
    if M.ndim != 3 or M.shape[0] != batch or M.shape[1] != M.shape[2]:
        raise ValueError(f"{name} must be (K+1, K+1) or (B={batch}, K+1, K+1), got {tuple(M.shape)}")
    return M


def _rows(M: Tensor, idx: Tensor) -> Tensor:
    """M[idx] for shared M, M[b, idx[b]] per sample: (B, L) indices -> (B, L, K+1) rows."""
    if M.ndim == 2:
        return M[idx]
    return M[torch.arange(M.shape[0], device=idx.device)[:, None], idx]


def _columns(M: Tensor, idx: Tensor, upto: int | None = None) -> Tensor:
    """Column ``idx`` of M as a function of the row: (B, L) indices -> (B, L, rows)."""
    rows = slice(None) if upto is None else slice(0, upto)
    if M.ndim == 2:
        return M[rows, idx].permute(1, 2, 0)
    return M[torch.arange(M.shape[0], device=idx.device)[:, None], rows, idx]


def _check_tokens(x: Tensor, name: str, n_states: int) -> None:
    if x.ndim != 2 or x.dtype != torch.long:
        raise ValueError(f"{name} must be a (B, L) long tensor, got {tuple(x.shape)} {x.dtype}")
    if x.numel() and values_checked(x) and (x.min() < 0 or x.max() >= n_states):
        raise ValueError(f"{name} must hold ids in [0, {n_states}), got range [{x.min()}, {x.max()}]")


def log_q_xt_given_x0(x0: Tensor, cumulative: Tensor) -> Tensor:
    """log q(x_t | x_0) = log Q̄_t[x_0, :]: (B, L) ids -> (B, L, K+1).

    ``cumulative`` is Q̄_t, shared (K+1, K+1) or per sample (B, K+1, K+1).
    """
    _check_tokens(x0, "x0", cumulative.shape[-1])
    return safe_log(_rows(_check_matrix(cumulative, x0.shape[0], "cumulative"), x0))


def gumbel_sample(log_probs: Tensor, generator: torch.Generator) -> Tensor:
    """Draw one category per row by Gumbel-max: argmax(log p + g), g = −log(−log u).

    The uniform noise is drawn on the generator's device and then moved, so a seed gives the same draw
    wherever ``log_probs`` lives.
    """
    if not isinstance(generator, torch.Generator):
        raise ValueError("generator is required: pass a seeded torch.Generator")
    u = torch.rand(log_probs.shape, generator=generator, device=generator.device, dtype=torch.float32)
    g = -torch.log(-torch.log(u.clamp(1e-20, 1.0 - 1e-7)))
    return (log_probs + g.to(log_probs.device, log_probs.dtype)).argmax(dim=-1)


def q_sample(x0: Tensor, cumulative: Tensor, generator: torch.Generator) -> Tensor:
    """x_t ~ q(x_t | x_0) = Q̄_t[x_0, :] by Gumbel-max: (B, L) ids -> (B, L) ids in [0, K]."""
    return gumbel_sample(log_q_xt_given_x0(x0, cumulative), generator)


def log_q_posterior(x0: Tensor, x_t: Tensor, step: Tensor, cum_prev: Tensor) -> Tensor:
    """The true posterior log q(x_s | x_t, x_0) ∝ log step[x_s, x_t] + log Q̄_s[x_0, x_s]: -> (B, L, K+1).

    ``step`` = q(x_t | x_s) (Q_t when s = t − 1) and ``cum_prev`` = Q̄_s; normalised over x_s by logsumexp.
    """
    B = x_t.shape[0]
    step, cum_prev = _check_matrix(step, B, "step"), _check_matrix(cum_prev, B, "cum_prev")
    _check_tokens(x_t, "x_t", step.shape[-1])
    _check_tokens(x0, "x0", step.shape[-1] - 1)
    if x0.shape != x_t.shape:
        raise ValueError(f"x0 {tuple(x0.shape)} and x_t {tuple(x_t.shape)} must have the same shape")
    logits = _log(_columns(step, x_t)) + _log(_rows(cum_prev, x0))  # (B, L, K+1), −inf where impossible
    return _normalise(logits)


@in_fp32  # transition matrices and log-probabilities stay fp32 under bf16 autocast
def log_p_posterior(log_p_x0: Tensor, x_t: Tensor, step: Tensor, cum_prev: Tensor, cum_t: Tensor) -> Tensor:
    """The model's reverse step log p_θ(x_s | x_t) = log Σ_{x0} q(x_s | x_t, x0) p_θ(x0 | x_t): -> (B, L, K+1).

    Args:
        log_p_x0: (B, L, K) log p_θ(x_0 | x_t) over the K codes (the network's output).
        x_t: (B, L) current ids in [0, K].
        step: q(x_t | x_s), (K+1, K+1) or (B, K+1, K+1).
        cum_prev: Q̄_s, same layout.
        cum_t: Q̄_t = Q̄_s · step, same layout (supplies the per-x_0 normaliser q(x_t | x_0)).
    """
    B = x_t.shape[0]
    step, cum_prev = _check_matrix(step, B, "step"), _check_matrix(cum_prev, B, "cum_prev")
    cum_t = _check_matrix(cum_t, B, "cum_t")
    K = step.shape[-1] - 1
    _check_tokens(x_t, "x_t", K + 1)
    if log_p_x0.shape != (*x_t.shape, K):
        raise ValueError(f"log_p_x0 must be (B, L, K) = {(*x_t.shape, K)}, got {tuple(log_p_x0.shape)}")
    q_t = _columns(cum_t, x_t, upto=K)  # (B, L, K): q(x_t | x0) for every x0
    # An x0 that cannot reach x_t (q = 0, e.g. under pure masking) takes no part: −inf, not a floored log.
    log_ratio = torch.where(q_t > 0, log_p_x0 - _log(q_t), float("-inf"))  # log p(x0) − log q(x_t | x0)
    peak = log_ratio.max(dim=-1, keepdim=True).values.clamp_min(-1e30)  # finite even if no x0 is possible
    mixed = torch.matmul((log_ratio - peak).exp(), cum_prev[..., :K, :])  # (B, L, K+1): Σ_x0 (·) Q̄_s[x0, x_s]
    logits = _log(mixed) + peak + _log(_columns(step, x_t))
    # Exact algebra makes this normalised already; renormalising removes float32 rounding of the matrices.
    return _normalise(logits)


def _log(p: Tensor) -> Tensor:
    """log p with an exact −inf at p = 0 and a finite gradient everywhere (torch.log's is 0/0 = NaN there)."""
    return torch.where(p > 0, torch.log(p.clamp_min(torch.finfo(p.dtype).tiny)), float("-inf"))


def _normalise(logits: Tensor) -> Tensor:
    """Log-softmax over the last axis that tolerates −inf entries (and all-−inf rows), floored at LOG_FLOOR."""
    lse = logits.logsumexp(dim=-1, keepdim=True)
    lse = torch.where(torch.isfinite(lse), lse, torch.zeros_like(lse))
    return (logits - lse).clamp_min(LOG_FLOOR)
