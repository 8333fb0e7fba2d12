"""Training objective of the denoiser (VQ-Diffusion; M2D2M Eq. 3).

For a uniformly drawn step t ∈ {1..T} and x_t ~ q(x_t | x_0), per token::

    L_t = KL( q(x_{t-1} | x_t, x_0) ‖ p_θ(x_{t-1} | x_t) )      for t ≥ 2
    L_1 = −log p_θ(x_0 | x_1)                                    (the decoder term of the bound)
    aux = −log p_θ(x_0 | x_t)                                    (M2D2M Eq. 3's λ term; = KL(δ_{x_0} ‖ p_θ))
    loss = (L_t + λ · aux) / p(t),    λ = 5e-4,  p(t) = 1/T

Dividing by p(t) makes L_t / p(t) an unbiased estimate of the whole bound Σ_t L_t (VQ-Diffusion does the
same, which is what its λ = 5e-4 was tuned against). The result is a mean over real (non-padding) tokens.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor, nn

from motionlab.checks import values_checked
from motionlab.diffusion.posterior import LOG_FLOOR, log_p_posterior, log_q_posterior, q_sample
from motionlab.diffusion.transitions import Transitions
from motionlab.precision import in_fp32
from motionlab.train.device import model_device, to_device

AUX_WEIGHT = 5e-4  # λ of M2D2M Eq. 3 (appendix A.1)


@dataclass
class DiffusionLoss:
    """One batch's loss and its parts (token means, before the 1/p(t) factor for ``vb`` and ``aux``)."""

    loss: Tensor  # scalar, what to backpropagate
    vb: Tensor  # scalar, mean L_t over tokens
    aux: Tensor  # scalar, mean −log p_θ(x_0 | x_t)
    t: Tensor  # (B,) the steps drawn


def sample_timesteps(batch: int, T: int, generator: torch.Generator) -> Tensor:
    """(B,) steps drawn uniformly from {1, ..., T} (on the generator's device)."""
    if not isinstance(generator, torch.Generator):
        raise ValueError("generator is required: pass a seeded torch.Generator")
    return torch.randint(1, T + 1, (batch,), generator=generator, device=generator.device)


@in_fp32  # posteriors and KL terms stay fp32 under bf16 autocast
def vb_terms(log_p_x0: Tensor, x0: Tensor, x_t: Tensor, t: Tensor, transitions: Transitions) -> tuple[Tensor, Tensor]:
    """Per-token bound term L_t and auxiliary term −log p_θ(x_0 | x_t), both (B, L).

    Args:
        log_p_x0: (B, L, K) network output log p_θ(x_0 | x_t).
        x0, x_t: (B, L) ids; t: (B,) steps in [1, T].
    """
    if t.ndim != 1 or t.shape[0] != x0.shape[0] or (values_checked(t) and (t.min() < 1 or t.max() > transitions.T)):
        raise ValueError(f"t must be (B,) with values in [1, {transitions.T}], got {tuple(t.shape)}")
    t = t.to(transitions.one_step.device)
    step, cum_prev, cum_t = (
        m.to(x0.device) for m in (transitions.one_step[t], transitions.cumulative[t - 1], transitions.cumulative[t])
    )
    log_q = log_q_posterior(x0, x_t, step, cum_prev)  # (B, L, K+1)
    log_p = log_p_posterior(log_p_x0, x_t, step, cum_prev, cum_t)  # (B, L, K+1)
    kl = (log_q.exp() * (log_q - log_p)).sum(dim=-1)  # (B, L)
    nll = -log_p_x0.gather(-1, x0.unsqueeze(-1)).squeeze(-1).clamp_min(LOG_FLOOR)  # (B, L)
    first = (t == 1).to(x0.device)[:, None]
    return torch.where(first, nll, kl), nll


def _check_diffusion_loss_inputs(x0: Tensor, padding_mask: Tensor | None, K: int) -> None:
    """Reject ``x0`` that is not a non-empty ``(B, L)`` tensor of ids in ``[0, K)`` and a mismatched mask."""
    if x0.ndim != 2 or x0.dtype != torch.long or x0.numel() == 0:
        raise ValueError(f"x0 must be a non-empty (B, L) long tensor, got {tuple(x0.shape)} {x0.dtype}")
    if values_checked(x0) and (x0.min() < 0 or x0.max() >= K):
        raise ValueError(f"x0 must hold code ids in [0, {K}), got range [{x0.min()}, {x0.max()}]")
    if padding_mask is not None and padding_mask.shape != x0.shape:
        raise ValueError(f"padding_mask must be (B, L) = {tuple(x0.shape)}, got {tuple(padding_mask.shape)}")


def diffusion_loss(
    model: nn.Module,
    transitions: Transitions,
    x0: Tensor,
    text: Tensor,
    text_padding_mask: Tensor | None = None,
    padding_mask: Tensor | None = None,
    *,
    generator: torch.Generator,
    aux_weight: float = AUX_WEIGHT,
    cond_drop_prob: float = 0.1,
    t: Tensor | None = None,
) -> DiffusionLoss:
    """Draw t and x_t, run the denoiser, and return the per-token loss.

    Args:
        model: called as ``model(x_t, t, text, text_padding_mask, padding_mask=..., cond_drop_prob=...,
            generator=...)`` and returning (B, L, K) log p_θ(x_0 | x_t) (:class:`DenoisingTransformer`).
        x0: (B, L) clean token ids in [0, K).
        text: (B, S, text_dim) text token features; ``text_padding_mask`` (B, S), True at padding.
        padding_mask: (B, L), True at padded motion tokens (excluded from the mean, kept masked in x_t).
        generator: drives t, x_t and the text dropout (10 % by default, for classifier-free guidance).
        t: optional (B,) steps to use instead of drawing them.
    """
    K = transitions.num_codes
    _check_diffusion_loss_inputs(x0, padding_mask, K)
    dev = model_device(model, x0.device)  # the batch joins the network (a no-op for the trainer's batches)
    x0, text, text_padding_mask, padding_mask = to_device((x0, text, text_padding_mask, padding_mask), dev)
    B = x0.shape[0]
    if t is None:
        t = sample_timesteps(B, transitions.T, generator)
    t = t.to(x0.device)
    rows = transitions.cumulative[t.to(transitions.cumulative.device)].to(x0.device)  # Q̄_t of each clip
    x_t = q_sample(x0, rows, generator).to(x0.device)
    if padding_mask is not None:
        x_t = x_t.masked_fill(padding_mask, K)
    log_p_x0 = model(
        x_t, t, text, text_padding_mask, padding_mask=padding_mask, cond_drop_prob=cond_drop_prob, generator=generator
    )
    vb, aux = vb_terms(log_p_x0, x0, x_t, t, transitions)  # (B, L) each
    weight = torch.ones_like(vb) if padding_mask is None else (~padding_mask).to(vb.dtype)
    denom = weight.sum().clamp_min(1.0)
    inv_pt = float(transitions.T)  # 1 / p(t) for uniform t
    vb_mean, aux_mean = (vb * weight).sum() / denom, (aux * weight).sum() / denom
    return DiffusionLoss(inv_pt * (vb_mean + aux_weight * aux_mean), vb_mean.detach(), aux_mean.detach(), t)
