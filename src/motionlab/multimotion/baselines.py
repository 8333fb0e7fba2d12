"""Multi-motion baselines on the same denoiser and the same token budget as Two-Phase Sampling.

* **Independent** (the T2M-GPT baseline of M2D2M Table 1): every action sampled alone
  (:func:`independent_sample`, plain :func:`motionlab.diffusion.sample` on the batch of segments); the tokens
  are then concatenated and decoded as one sequence (appendix A.2: "codebooks were concatenated ... and fed
  into the decoder"), or each segment is decoded alone and the *features* concatenated. Token-wise this is
  exactly TPS with ``T_s = T``.
* **SLERP** (after TEACH; M2D2M Table 6): every action is generated ``W/2`` frames shorter at each inner end
  (:func:`shortened_lengths`), decoded alone, and consecutive segments are joined by ``W`` blended frames
  (:func:`motionlab.multimotion.stitch.blend_segments`); lengths and boundaries come out as requested.
* **Handshake** (PriorMDM's DoubleTake, first take; M2D2M uses a 40-frame handshake): consecutive actions
  are generated *together* and share ``W`` frames around their boundary. Here, in tokens
  (:func:`handshake_sample`): each action's window is extended by ``W/2`` frames (``W/8`` tokens) into each
  neighbour (:func:`handshake_windows`), so neighbouring windows overlap by ``W/4`` tokens centred on the
  boundary. One state lives on the canvas (the whole sequence); at every step each window is denoised with
  its own text (a batch of windows), and where windows overlap their predictions p_θ(x_0 | x_t) are
  **averaged** (the mean of the probabilities: MDM's handshake averages its x_0 predictions) before
  truncation, the posterior and one shared draw. Everything outside the overlaps sees one window only.
  DoubleTake's second take (re-generating the transitions with soft masks) is not included.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor, nn

from motionlab.diffusion import (
    Transitions,
    check_guidance_space,
    classifier_free_guidance,
    gumbel_sample,
    log_p_posterior,
    sample,
    truncate,
)
from motionlab.multimotion.tps import (
    MultiMotionTokens,
    SegmentLayout,
    phase_grid,
    segment_layout,
    text_tensors,
)
from motionlab.precision import in_precision, network_precision
from motionlab.train.device import model_device

DEFAULT_TRANSITION = 40  # frames: M2D2M's transition window and handshake size


def _check_transition(transition: int, unit: int) -> int:
    if not isinstance(transition, int) or transition <= 0 or transition % (2 * unit):
        raise ValueError(
            f"transition must be a positive multiple of {2 * unit} frames (half of it on each "
            f"side of a boundary, in whole tokens), got {transition!r}"
        )
    return transition // 2


@torch.no_grad()
def independent_sample(
    model: nn.Module, transitions: Transitions, text, segment_lengths, *, generator: torch.Generator, **sampling
) -> MultiMotionTokens:
    """Each action alone: :func:`motionlab.diffusion.sample` over the batch of all segments (``sampling``:
    ``num_steps``, ``timesteps``, ``guidance_scale``, ``guidance_on``, ``top_p``, ``top_k``); ids on the model's
    device."""
    layout = segment_layout(segment_lengths)
    tokens, pad = text_tensors(text, layout.n_segments)
    ids = sample(model, transitions, tokens, pad, lengths=layout.flat_tokens, generator=generator, **sampling)
    return MultiMotionTokens(ids, layout, sampling.get("pad_id", -1))


def shortened_lengths(lengths: Sequence[int], transition: int = DEFAULT_TRANSITION, unit: int = 4) -> list[int]:
    """SLERP's generation lengths: ``transition / 2`` frames fewer at each inner end of an action.

    >>> shortened_lengths([100, 80, 60])
    [80, 40, 40]
    """
    half = _check_transition(transition, unit)
    lengths = [int(n) for n in lengths]
    if not lengths:
        raise ValueError("lengths is empty")
    inner = [(i > 0) + (i < len(lengths) - 1) for i in range(len(lengths))]
    out = [n - half * k for n, k in zip(lengths, inner, strict=True)]
    if any(n < unit for n in out):
        raise ValueError(
            f"actions of {lengths} frames are too short for a {transition}-frame transition: each "
            f"needs {unit} frames left after giving {half} to every neighbour"
        )
    return out


def handshake_windows(layout: SegmentLayout, transition: int = DEFAULT_TRANSITION) -> list[tuple[int, int, int]]:
    """(instance, start, stop) canvas token range of every action's handshake window.

    Action i covers its own tokens plus ``transition / 8`` tokens of each neighbour (clipped to the
    instance), so two neighbours share ``transition / 4`` tokens = ``transition`` frames around their boundary.
    """
    half_tokens = _check_transition(transition, layout.unit) // layout.unit
    out = []
    for b, offset, n in layout.placements:
        n_actions, total = len(layout.tokens[b]), layout.total_tokens[b]
        first, last = offset == 0, offset + n == total
        start = offset if first or n_actions == 1 else max(0, offset - half_tokens)
        stop = offset + n if last or n_actions == 1 else min(total, offset + n + half_tokens)
        out.append((b, start, stop))
    return out


def _log_p_x0_branches(model, x, t: int, tokens, text_pad, padding_mask, guided: bool) -> list[Tensor]:
    """log p_θ(x_0 | x_t) of a batch with the text, and without it when ``guided`` (one doubled network call)."""
    B = x.shape[0]
    steps = torch.full((B,), t, dtype=torch.long, device=x.device)
    model = in_precision(model, network_precision(x.device), x.device)
    if not guided:
        return [model(x, steps, tokens, text_pad, padding_mask=padding_mask)]
    drop = torch.cat([torch.zeros(B, dtype=torch.bool), torch.ones(B, dtype=torch.bool)]).to(x.device)
    two = lambda v: torch.cat([v, v])  # noqa: E731
    out = model(two(x), two(steps), two(tokens), two(text_pad), padding_mask=two(padding_mask), drop_text=drop)
    return [out[:B], out[B:]]


@torch.no_grad()
def handshake_sample(
    model: nn.Module,
    transitions: Transitions,
    text,
    segment_lengths,
    *,
    generator: torch.Generator,
    transition: int = DEFAULT_TRANSITION,
    num_steps: int | None = None,
    timesteps: Sequence[int] | None = None,
    guidance_scale: float = 0.0,
    guidance_on: str = "x0",
    top_p: float | None = None,
    top_k: int | None = None,
    pad_id: int = -1,
) -> MultiMotionTokens:
    """Handshake sampling (see the module docstring): returns the same layout as :func:`two_phase_sample`, ids on
    the model's device. ``guidance_on="posterior"`` guides p_θ(x_{t-1} | x_t) instead of p_θ(x_0 | x_t), as
    :func:`motionlab.diffusion.reverse_step` does: the window means are then taken with and without the text apart."""
    check_guidance_space(guidance_on)
    layout = segment_layout(segment_lengths)
    tokens, text_pad = text_tensors(text, layout.n_segments)
    grid = phase_grid(transitions.T, transitions.T, num_steps, timesteps)
    windows = handshake_windows(layout, transition)
    dev, mask_id, K = model_device(model, tokens.device), transitions.mask_id, transitions.mask_id
    tokens, text_pad = tokens.to(dev), text_pad.to(dev)  # generated where the model lives
    L_c, w_max = layout.canvas_length, max(stop - start for _, start, stop in windows)
    # gather index (M, w_max) into the flattened canvas; padding points at a dummy slot past the end
    dummy = layout.n_instances * L_c
    gather = torch.full((layout.n_segments, w_max), dummy, dtype=torch.long)
    for m, (b, start, stop) in enumerate(windows):
        gather[m, : stop - start] = b * L_c + torch.arange(start, stop)
    gather = gather.to(dev)
    win_padding = gather == dummy  # (M, w_max)
    counts = torch.zeros(dummy + 1, device=dev).index_add_(0, gather.flatten(), torch.ones(gather.numel(), device=dev))
    canvas_padding = layout.canvas_padding(dev)  # (B, L_c)

    x = torch.full((layout.n_instances, L_c), mask_id, dtype=torch.long, device=dev)  # (B, L_c)
    for t, t_prev in zip(grid[:-1], grid[1:], strict=True):
        x_flat = torch.cat([x.flatten(), x.new_full((1,), mask_id)])
        x_win = x_flat[gather]  # (M, w_max)
        branches = _log_p_x0_branches(model, x_win, t, tokens, text_pad, win_padding, guidance_scale != 0.0)
        if len(branches) == 2 and guidance_on == "x0":
            branches = [classifier_free_guidance(*branches, guidance_scale)]  # (M, w_max, K)
        if t_prev > 0:  # q(x_t | x_{t_prev}), shared by both branches
            step = transitions.interval(t_prev, t).to(dev)
            cum_prev, cum_t = transitions.cumulative[t_prev].to(dev), transitions.cumulative[t].to(dev)
        mixes = []
        for log_p in branches:
            mixed = torch.zeros(dummy + 1, K, device=dev).index_add_(0, gather.flatten(), log_p.exp().flatten(0, 1))
            mixed = mixed[:dummy] / counts[:dummy, None].clamp_min(1)  # mean over the windows covering a token
            log_mix = truncate(mixed.clamp_min(1e-30).log().view(layout.n_instances, L_c, K), top_p, top_k)
            if t_prev > 0:
                log_mix = log_p_posterior(log_mix, x, step, cum_prev, cum_t)
            mixes.append(log_mix)
        log_prev = mixes[0] if len(mixes) == 1 else classifier_free_guidance(*mixes, guidance_scale)
        x = gumbel_sample(log_prev, generator).masked_fill(canvas_padding, mask_id)
    ids = layout.split(x, mask_id).masked_fill(layout.batch_padding(dev), pad_id)
    return MultiMotionTokens(ids, layout, pad_id)
