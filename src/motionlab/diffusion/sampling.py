"""Reverse-process samplers: ancestral (every step), fast (skipping steps), guidance and truncation.

One step from t to s < t (:func:`denoise_step`: the network's prediction, then :func:`reverse_step`):

1. log p_θ(x_0 | x_t) from the network, with classifier-free guidance (:func:`classifier_free_guidance`);
2. truncate it to its most likely codes (top-p / top-k, :func:`truncate`), as VQ-Diffusion does;
3. log p_θ(x_s | x_t) = log Σ_{x0} q(x_s | x_t, x0) p_θ(x0 | x_t) with q(x_t | x_s) = Q_{s+1}⋯Q_t — the
   exact posterior *jump*, so skipping steps needs no approximation (s = 0 samples x_0 directly);
4. draw x_s by Gumbel-max.

:func:`sample` runs it from all-mask over a grid T = t_0 > t_1 > … > 0. Two-Phase Sampling can call
:func:`denoise_step` itself: jointly over concatenated segments (``cross_mask``) for t > T_s, then per segment.

**Guidance scale.** M2D2M Eq. 9 writes log p = (s + 1)·log p(·|y) − s·log p(·|∅) = log p_c + s·(log p_c − log p_u),
so s = 0 is the plain conditional model, and the paper's s = 4 (single motions) / s = 2 (multi-motion)
are *extra* weight on the text. VQ-Diffusion's code writes log p_u + g·(log p_c − log p_u): the same thing
with g = 1 + s (its default g = 1 is "off"). ``guidance_scale`` here is M2D2M's s; the result is
renormalised. By default it is applied to p_θ(x_0 | x_t), as VQ-Diffusion's code does; ``guidance_on =
"posterior"`` applies it to p_θ(x_{t-1} | x_t), the distribution Eq. 9 literally names.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
from torch import Tensor, nn

from motionlab.diffusion.posterior import LOG_FLOOR, gumbel_sample, log_p_posterior
from motionlab.diffusion.transitions import Transitions
from motionlab.precision import in_precision, network_autocast, network_precision
from motionlab.train.device import model_device, to_device

GUIDANCE_SPACES = ("x0", "posterior")


def timestep_grid(T: int, num_steps: int | None = None) -> list[int]:
    """Descending steps [T, …, 0] with ``num_steps`` jumps (None: all T, i.e. ancestral sampling)."""
    if num_steps is None:
        num_steps = T
    if not isinstance(num_steps, int) or not 1 <= num_steps <= T:
        raise ValueError(f"num_steps must be an int in [1, T={T}], got {num_steps!r}")
    grid = torch.linspace(T, 0, num_steps + 1, dtype=torch.float64).round().long().tolist()
    return sorted(set(grid), reverse=True)


def classifier_free_guidance(log_p_cond: Tensor, log_p_uncond: Tensor, scale: float) -> Tensor:
    """M2D2M Eq. 9: log p ∝ log p_c + s·(log p_c − log p_u), renormalised (s = 0: the conditional model)."""
    guided = log_p_cond + scale * (log_p_cond - log_p_uncond)
    return (guided - guided.logsumexp(dim=-1, keepdim=True)).clamp_min(LOG_FLOOR)


def truncate(log_p: Tensor, top_p: float | None = None, top_k: int | None = None) -> Tensor:
    """Keep the most likely classes of each distribution and renormalise; the rest get ``LOG_FLOOR``.

    top-p (nucleus, VQ-Diffusion's "top{r}r"): sorted by probability, class i is kept when the mass of the
    classes before it is < p, i.e. the smallest prefix holding at least p (never empty).
    top-k: the k most likely classes. Both may be given (the intersection is kept).
    """
    if top_p is None and top_k is None:
        return log_p
    keep = torch.ones_like(log_p, dtype=torch.bool)
    if top_p is not None:
        if not 0.0 < top_p <= 1.0:
            raise ValueError(f"top_p must be in (0, 1], got {top_p}")
        sorted_lp, order = log_p.sort(dim=-1, descending=True)
        before = sorted_lp.exp().cumsum(dim=-1) - sorted_lp.exp()  # mass strictly before each sorted class
        keep_sorted = before < top_p
        keep_sorted[..., 0] = True
        keep = keep & torch.zeros_like(keep).scatter(-1, order, keep_sorted)
    if top_k is not None:
        if not isinstance(top_k, int) or not 1 <= top_k <= log_p.shape[-1]:
            raise ValueError(f"top_k must be an int in [1, {log_p.shape[-1]}], got {top_k!r}")
        kth = log_p.topk(top_k, dim=-1).values[..., -1:]
        keep = keep & (log_p >= kth)
    kept = log_p.masked_fill(~keep, float("-inf"))
    return (kept - kept.logsumexp(dim=-1, keepdim=True)).clamp_min(LOG_FLOOR)


ROWS_PER_CALL = 32  # rows of a padded batch the network sees at once, grouped by length


def _network_log_p_x0(
    model: nn.Module, x_t: Tensor, t: int, text: Tensor, guided: bool, **kw
) -> tuple[Tensor, Tensor | None]:
    """Conditional (and, if guided, unconditional) log p_θ(x_0 | x_t) from one batched network call."""
    B = x_t.shape[0]
    steps = torch.full((B,), t, dtype=torch.long, device=x_t.device)
    model = in_precision(model, network_precision(x_t.device), x_t.device)  # log-probabilities come back fp32
    if not guided:
        return model(x_t, steps, text, **kw), None
    double = {k: (torch.cat([v, v]) if torch.is_tensor(v) else v) for k, v in kw.items()}
    drop = torch.cat([torch.zeros(B, dtype=torch.bool), torch.ones(B, dtype=torch.bool)]).to(x_t.device)
    out = model(torch.cat([x_t, x_t]), torch.cat([steps, steps]), torch.cat([text, text]), drop_text=drop, **double)
    return out[:B], out[B:]


def _rows(kw: dict, rows: Tensor, extent: int) -> dict:
    """The keyword tensors of ``rows``, cropped to the first ``extent`` motion positions."""
    out = dict(kw)
    for name in ("padding_mask", "cross_mask"):  # (B, L) and (B, L, S): the motion axis is dim 1
        if out.get(name) is not None:
            out[name] = out[name][rows, :extent]
    if out.get("text_padding_mask") is not None:
        out["text_padding_mask"] = out["text_padding_mask"][rows]
    return out


def _model_log_p_x0(
    model: nn.Module, x_t: Tensor, t: int, text: Tensor, guided: bool, *, rows_per_call: int | None = None, **kw
) -> tuple[Tensor, Tensor | None]:
    """log p_θ(x_0 | x_t) of a padded batch, the network run only where there is motion.

    A padded position costs as much as a real one, and a batch of segments of 40–196 frames is about a third
    padding. So rows are grouped by how far their motion reaches, ``rows_per_call`` at a time (one call when
    the batch is that small), and each group is cropped to its longest row. The padding never reaches a real
    position (it is masked out of the attention), so real positions get what one call over the whole batch
    gives, up to float rounding; padded positions get a uniform distribution (their draws are masked after).
    Two samplers that both come here see the same numbers, which keeps Two-Phase Sampling with T_s = T
    bit-identical to :func:`sample`.
    """
    padding, rows_per_call = kw.get("padding_mask"), rows_per_call or ROWS_PER_CALL
    if padding is None or kw.get("self_mask") is not None:
        return _network_log_p_x0(model, x_t, t, text, guided, **kw)
    B, L = x_t.shape
    position = torch.arange(1, L + 1, device=x_t.device)
    extent = torch.where(padding.bool(), 0, position).amax(dim=1)  # (B,) last real position + 1
    if B <= rows_per_call:
        reach = int(extent.max())
        if reach in (0, L):  # nothing to crop
            return _network_log_p_x0(model, x_t, t, text, guided, **kw)
        groups = [torch.arange(B, device=x_t.device)]
    else:
        order = torch.sort(extent, stable=True).indices
        groups = [g for g in order.split(rows_per_call) if int(extent[g].max()) > 0]
        if not groups:  # every row is padding
            return _network_log_p_x0(model, x_t, t, text, guided, **kw)
    log_c = log_u = None
    for rows in groups:
        reach = int(extent[rows].max())
        part_c, part_u = _network_log_p_x0(model, x_t[rows, :reach], t, text[rows], guided, **_rows(kw, rows, reach))
        if log_c is None:  # uniform where the network did not run
            uniform = -math.log(part_c.shape[-1])
            log_c = part_c.new_full((B, L, part_c.shape[-1]), uniform)
            log_u = log_c.clone() if guided else None
        log_c[rows, :reach] = part_c
        if guided:
            log_u[rows, :reach] = part_u
    return log_c, log_u


def check_guidance_space(guidance_on: str) -> None:
    """Reject a guidance space other than :data:`GUIDANCE_SPACES` (every sampler and config that takes one)."""
    if guidance_on not in GUIDANCE_SPACES:
        raise ValueError(f"guidance_on must be one of {GUIDANCE_SPACES}, got {guidance_on!r}")


def _check_denoise_step_inputs(transitions: Transitions, t: int, t_prev: int, guidance_on: str) -> None:
    """Reject steps outside ``0 <= t_prev < t <= T`` and an unknown guidance space."""
    if not (0 <= t_prev < t <= transitions.T):
        raise ValueError(f"need 0 <= t_prev < t <= T={transitions.T}, got t={t}, t_prev={t_prev}")
    check_guidance_space(guidance_on)


def reverse_step(
    transitions: Transitions,
    log_p_x0: Tensor,
    x_t: Tensor,
    t: int,
    t_prev: int,
    generator: torch.Generator,
    *,
    log_p_x0_null: Tensor | None = None,
    guidance_scale: float = 0.0,
    guidance_on: str = "x0",
    top_p: float | None = None,
    top_k: int | None = None,
) -> Tensor:
    """Draw x_{t_prev} ~ p_θ(x_{t_prev} | x_t) from the network's log p_θ(x_0 | x_t): (B, L, K) -> (B, L) ids.

    ``log_p_x0_null`` is the prediction without the text, p_θ(x_0 | x_t, ∅): given, it guides with ``guidance_scale``
    (M2D2M Eq. 9), on p_θ(x_0 | x_t) or, with ``guidance_on="posterior"``, on p_θ(x_{t_prev} | x_t).
    """
    branches = [log_p_x0] if log_p_x0_null is None else [log_p_x0, log_p_x0_null]
    if len(branches) == 2 and guidance_on == "x0":  # 1. guidance on the predicted x_0
        branches = [classifier_free_guidance(log_p_x0, log_p_x0_null, guidance_scale)]
    branches = [truncate(lp, top_p, top_k) for lp in branches]  # 2. keep the likeliest codes
    if t_prev > 0:  # 3. p(x_s | x_t) = Σ_x0 q(x_s | x_t, x0) p(x0 | x_t), with q(x_t | x_s) = Q_{s+1}⋯Q_t
        step = transitions.interval(t_prev, t).to(x_t.device)
        cum_prev, cum_t = transitions.cumulative[t_prev].to(x_t.device), transitions.cumulative[t].to(x_t.device)
        branches = [log_p_posterior(lp, x_t, step, cum_prev, cum_t) for lp in branches]
    # (at t_prev = 0 the step is p(x0 | x_t) itself)
    log_prev = branches[0] if len(branches) == 1 else classifier_free_guidance(*branches, guidance_scale)
    return gumbel_sample(log_prev, generator)  # 4. draw


@torch.no_grad()
def denoise_step(
    model: nn.Module,
    transitions: Transitions,
    x_t: Tensor,
    t: int,
    t_prev: int,
    text: Tensor,
    text_padding_mask: Tensor | None = None,
    *,
    generator: torch.Generator,
    guidance_scale: float = 0.0,
    guidance_on: str = "x0",
    top_p: float | None = None,
    top_k: int | None = None,
    padding_mask: Tensor | None = None,
    cross_mask: Tensor | None = None,
    self_mask: Tensor | None = None,
) -> Tensor:
    """One reverse jump x_t -> x_{t_prev} (0 <= t_prev < t <= T): (B, L) ids -> (B, L) ids.

    The network's log p_θ(x_0 | x_t) (and, guided, its prediction without the text), then :func:`reverse_step`.
    Padded positions (``padding_mask`` True) stay masked. At ``t_prev = 0`` the result holds codes only. The inputs
    are moved to the model's device, where the step runs; the result is returned on ``x_t``'s device.
    """
    _check_denoise_step_inputs(transitions, t, t_prev, guidance_on)
    where, dev = x_t.device, model_device(model, x_t.device)
    x_t, text, text_padding_mask, padding_mask, cross_mask, self_mask = to_device(
        (x_t, text, text_padding_mask, padding_mask, cross_mask, self_mask), dev
    )
    kw = dict(
        text_padding_mask=text_padding_mask, padding_mask=padding_mask, cross_mask=cross_mask, self_mask=self_mask
    )
    guided = guidance_scale != 0.0
    log_c, log_u = _model_log_p_x0(model, x_t, t, text, guided, **kw)
    x_prev = reverse_step(
        transitions,
        log_c,
        x_t,
        t,
        t_prev,
        generator,
        log_p_x0_null=log_u,
        guidance_scale=guidance_scale,
        guidance_on=guidance_on,
        top_p=top_p,
        top_k=top_k,
    )
    if padding_mask is not None:
        x_prev = x_prev.masked_fill(padding_mask, transitions.mask_id)
    return x_prev.to(where)


@torch.no_grad()
def sample(
    model: nn.Module,
    transitions: Transitions,
    text: Tensor,
    text_padding_mask: Tensor | None = None,
    *,
    lengths: Sequence[int] | Tensor,
    generator: torch.Generator,
    num_steps: int | None = None,
    timesteps: Sequence[int] | None = None,
    guidance_scale: float = 0.0,
    guidance_on: str = "x0",
    top_p: float | None = None,
    top_k: int | None = None,
    pad_id: int = -1,
) -> Tensor:
    """Generate token ids from all-mask.

    Args:
        text: (B, S, text_dim) text token features, ``text_padding_mask`` (B, S) True at padding.
        lengths: B token counts; the output is (B, max(lengths)) with ``pad_id`` beyond each length.
        num_steps: jumps on an even grid (None: all T steps, ancestral); or give ``timesteps`` explicitly,
            a descending list from T to 0.
        guidance_scale: M2D2M's s (0 = conditional model; the paper uses 4 for single motions).
        top_p / top_k: truncation of p_θ(x_0 | x_t) at every step (VQ-Diffusion's default is top_p = 0.85).

    The text is moved to the model's device, where the ids are generated and returned.
    """
    lengths = torch.as_tensor(lengths, dtype=torch.long).flatten()
    B = text.shape[0] if torch.is_tensor(text) and text.ndim == 3 else -1
    if lengths.numel() != B or lengths.min() < 1:
        raise ValueError(f"lengths must hold B={B} positive counts (text: (B, S, d)), got {lengths.tolist()}")
    grid = list(timesteps) if timesteps is not None else timestep_grid(transitions.T, num_steps)
    if grid[0] != transitions.T or grid[-1] != 0 or any(a <= b for a, b in zip(grid, grid[1:], strict=False)):
        raise ValueError(f"timesteps must descend strictly from T={transitions.T} to 0, got {grid}")
    dev = model_device(model, text.device)  # the ids are generated (and returned) where the model lives
    text = text.to(dev)
    text_padding_mask = text_padding_mask.to(dev) if text_padding_mask is not None else None
    L = int(lengths.max())
    padding_mask = torch.arange(L, device=dev)[None, :] >= lengths.to(dev)[:, None]  # (B, L)
    x = torch.full((B, L), transitions.mask_id, dtype=torch.long, device=dev)
    with network_autocast(dev):  # posteriors stay fp32 (in_fp32); the network's weights are cast once
        for t, t_prev in zip(grid[:-1], grid[1:], strict=True):
            x = denoise_step(
                model,
                transitions,
                x,
                t,
                t_prev,
                text,
                text_padding_mask,
                generator=generator,
                guidance_scale=guidance_scale,
                guidance_on=guidance_on,
                top_p=top_p,
                top_k=top_k,
                padding_mask=padding_mask,
            )
    return x.masked_fill(padding_mask, pad_id)
