"""The tokenizer training objective of T2M-GPT and MoMask.

    L = SmoothL1(x̂, x) + λ_ric · SmoothL1(x̂[ric], x[ric]) + λ_commit · ‖z − sg(z_q)‖²

with λ_ric = 0.5 on the joint-position dims ric = 4 : 4 + 3(J − 1) (T2M-GPT calls this weight
``loss_vel`` although it weighs positions) and λ_commit = 0.02.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F


def ric_slice(n_joints: int) -> slice:
    """Feature dims of the root-relative joint positions: ``slice(4, 4 + 3 (J − 1))``."""
    return slice(4, 4 + 3 * (n_joints - 1))


def _check_tokenizer_loss_inputs(recon: torch.Tensor, target: torch.Tensor, n_joints: int) -> None:
    """Reject mismatched shapes and targets too narrow for ``n_joints`` joint positions."""
    if recon.shape != target.shape:
        raise ValueError(f"recon and target must match, got {tuple(recon.shape)} and {tuple(target.shape)}")
    ric = ric_slice(n_joints)
    if ric.stop > target.shape[-1]:
        raise ValueError(f"n_joints={n_joints} needs at least {ric.stop} feature dims, got {target.shape[-1]}")


def tokenizer_loss(
    recon: torch.Tensor,
    target: torch.Tensor,
    commit_loss: torch.Tensor,
    n_joints: int = 22,
    ric_weight: float = 0.5,
    commit_weight: float = 0.02,
) -> dict[str, torch.Tensor]:
    """Named loss terms for motion ``(B, T, D)``; ``"loss"`` is the weighted total to minimise."""
    _check_tokenizer_loss_inputs(recon, target, n_joints)
    ric = ric_slice(n_joints)
    recon_term = F.smooth_l1_loss(recon, target)
    ric_term = F.smooth_l1_loss(recon[..., ric], target[..., ric])
    total = recon_term + ric_weight * ric_term + commit_weight * commit_loss
    return {"loss": total, "recon": recon_term.detach(), "ric": ric_term.detach(), "commit": commit_loss.detach()}
