"""Condition projection: from token code vectors ``(B, N, d)`` to frame-wise features ``(B, q·N, d_feat)``.

A token summarises ``q`` consecutive frames (q = 4, the tokenizer's temporal downsampling), so the
decoder needs ``q`` *different* features per token, one per frame. DisCoRD's projection ("stacked"):

    z_n ∈ R^d  --repeat q times-->  (q, d)  --stack-->  R^{q·d}  --W ∈ R^{q·d × q·d}-->  R^{q·d}
              --unstack-->  q frame vectors in R^d  --per-frame linear d → d_feat-->  c_{qn}, …, c_{qn+q−1}

Each slot of the projected vector has its own rows of ``W``, so the q frames of one token get different
features, and no frame ever sees a neighbouring token (token ↔ frame correspondence is kept).
(As a function, "repeat then stack then W" equals one linear map d → q·d whose weight is the sum of W's
q column blocks; we keep the paper's form, which is what the public code trains.)

Ablations (DisCoRD Table 6):
- ``"repeat"``: nearest upsampling then a per-frame linear: the q frames of a token get *identical* features.
- ``"transposed"``: a strided transposed convolution (up-convolution). Its kernel is wider than the stride,
  so frames near a token boundary mix neighbouring tokens: the token ↔ frame correspondence is blurred.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

CONDITION_PROJECTIONS = ("stacked", "repeat", "transposed")


class _Projection(nn.Module):
    """Shared input check: ``(B, N, code_dim)`` in, ``(B, q·N, cond_dim)`` out."""

    def __init__(self, code_dim: int, cond_dim: int, q: int) -> None:
        super().__init__()
        self.code_dim, self.cond_dim, self.q = code_dim, cond_dim, q

    def forward(self, z: Tensor) -> Tensor:
        if not isinstance(z, Tensor) or z.dim() != 3 or z.shape[-1] != self.code_dim:
            got = tuple(z.shape) if isinstance(z, Tensor) else type(z).__name__
            raise ValueError(f"code vectors must have shape (B, N, {self.code_dim}), got {got}")
        return self.project(z)

    def project(self, z: Tensor) -> Tensor:
        raise NotImplementedError


class StackedProjection(_Projection):
    """DisCoRD: repeat each token q times, stack to q·d, linear q·d → q·d, unstack, linear d → d_feat."""

    def __init__(self, code_dim: int, cond_dim: int, q: int = 4) -> None:
        super().__init__(code_dim, cond_dim, q)
        self.stacked = nn.Linear(q * code_dim, q * code_dim)
        self.frame = nn.Linear(code_dim, cond_dim)

    def project(self, z: Tensor) -> Tensor:
        B, N, d = z.shape
        repeated = z.repeat_interleave(self.q, dim=1)  # (B, q·N, d): frame f carries token f // q
        stacked = repeated.reshape(B, N, self.q * d)  # (B, N, q·d): the q copies of token n side by side
        projected = self.stacked(stacked)  # (B, N, q·d)
        frames = projected.reshape(B, N * self.q, d)  # (B, q·N, d): unstack into q frame vectors
        return self.frame(frames)  # (B, q·N, d_feat)


class RepeatProjection(_Projection):
    """Ablation: nearest upsampling (repeat) then a per-frame linear d → d_feat; q identical features per token."""

    def __init__(self, code_dim: int, cond_dim: int, q: int = 4) -> None:
        super().__init__(code_dim, cond_dim, q)
        self.frame = nn.Linear(code_dim, cond_dim)

    def project(self, z: Tensor) -> Tensor:
        return self.frame(z.repeat_interleave(self.q, dim=1))  # (B, q·N, d_feat)


class TransposedConvProjection(_Projection):
    """Ablation: ``ConvTranspose1d(d → d_feat, kernel q + 2p, stride q, padding p)`` with ``p = q // 2``.

    Output length ``(N − 1)·q − 2p + (q + 2p) = q·N``; each output frame sees one or two tokens.
    """

    def __init__(self, code_dim: int, cond_dim: int, q: int = 4) -> None:
        super().__init__(code_dim, cond_dim, q)
        pad = q // 2
        self.up = nn.ConvTranspose1d(code_dim, cond_dim, kernel_size=q + 2 * pad, stride=q, padding=pad)

    def project(self, z: Tensor) -> Tensor:
        return self.up(z.transpose(1, 2)).transpose(1, 2)  # (B, d, N) -> (B, d_feat, q·N) -> (B, q·N, d_feat)


_KINDS: dict[str, type[_Projection]] = {
    "stacked": StackedProjection,
    "repeat": RepeatProjection,
    "transposed": TransposedConvProjection,
}


def make_condition_projection(kind: str, code_dim: int, cond_dim: int, q: int = 4) -> nn.Module:
    """Build a projection ``(B, N, code_dim) -> (B, q·N, cond_dim)``; ``kind`` in :data:`CONDITION_PROJECTIONS`."""
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {CONDITION_PROJECTIONS}, got {kind!r}")
    for name, value in (("code_dim", code_dim), ("cond_dim", cond_dim), ("q", q)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"{name} must be a positive int, got {value!r}")
    return _KINDS[kind](code_dim, cond_dim, q)


def frames_per_token_distinct(features: Tensor, q: int, atol: float = 1e-6) -> Tensor:
    """For frame features ``(B, q·N, d_feat)``, whether the q frames of each token differ: ``(B, N)`` bool.

    A diagnostic for the "q distinct features" property (the chapter plots it; the tests assert it).
    """
    B, T, d_feat = features.shape
    grouped = features.reshape(B, T // q, q, d_feat)  # (B, N, q, d_feat)
    spread = (grouped - grouped[:, :, :1]).abs().amax(dim=(2, 3))  # (B, N)
    return spread > atol


def _check_token_influence_inputs(projection: nn.Module, n_tokens: int) -> None:
    """Reject a non-positive ``n_tokens`` and a projection without a ``code_dim``."""
    if isinstance(n_tokens, bool) or not isinstance(n_tokens, int) or n_tokens < 1:
        raise ValueError(f"n_tokens must be a positive int, got {n_tokens!r}")
    if getattr(projection, "code_dim", None) is None:
        raise ValueError(f"projection must come from make_condition_projection, got {type(projection).__name__}")


@torch.no_grad()
def token_influence(projection: nn.Module, n_tokens: int = 6, seed: int = 0, atol: float = 1e-6) -> Tensor:
    """Which frames each token reaches: ``(N, q·N)`` bool, ``[n, f]`` true when bumping token ``n``'s code vector
    (by 1 in every dimension) changes frame ``f``'s features by more than ``atol``.

    The code vectors are one random draw (``seed``); the projection is linear, so the pattern does not depend on it.
    """
    _check_token_influence_inputs(projection, n_tokens)
    d = projection.code_dim
    base = torch.randn(1, n_tokens, d, generator=torch.Generator().manual_seed(seed))  # (1, N, d), drawn on the CPU
    base = base.to(next(projection.parameters()).device)  # the result lives on the projection's device
    reference = projection(base)  # (1, q·N, d_feat)
    rows = []
    for n in range(n_tokens):
        bumped = base.clone()
        bumped[0, n] += 1.0
        rows.append((projection(bumped) - reference).abs().amax(dim=-1)[0])  # (q·N,): largest change per frame
    return torch.stack(rows) > atol


def frames_reached_from_outside(influence: Tensor, q: int) -> Tensor:
    """From :func:`token_influence`'s ``(N, q·N)``: ``(q·N,)`` bool, whether a token other than the frame's own
    changes the frame (the token ↔ frame correspondence is broken there)."""
    n_tokens, n_frames = influence.shape
    if n_frames != q * n_tokens:
        raise ValueError(f"influence must have shape (N, {q}·N), got {tuple(influence.shape)}")
    own_token = torch.arange(n_frames) // q  # (q·N,)
    return (influence & (own_token[None, :] != torch.arange(n_tokens)[:, None])).any(dim=0)


__all__ = [
    "CONDITION_PROJECTIONS",
    "RepeatProjection",
    "StackedProjection",
    "TransposedConvProjection",
    "frames_per_token_distinct",
    "frames_reached_from_outside",
    "make_condition_projection",
    "token_influence",
]
