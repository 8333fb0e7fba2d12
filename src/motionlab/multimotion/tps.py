"""Two-Phase Sampling (M2D2M §4.3, Algorithm 1): several actions, one discrete-diffusion model.

Given N action texts a¹…a^N with lengths l_1…l_N (in tokens), start from an all-mask sequence of
Σ l_i tokens and run the reverse process in two phases::

    t = T … T_s+1   joint:        z_{t-1} ~ p_θ(z_{t-1} | z_t, y¹…y^N)     one sequence of Σ l_i tokens
    t = T_s … 1     independent:  z^i_{t-1} ~ p_θ(z^i_{t-1} | z^i_t, y^i)   N sequences, one per action
    z_0 = Concat(z^1_0, …, z^N_0)                                           decoded as one motion

**Joint phase.** Every token self-attends across the whole concatenated sequence (the relative position bias
of the denoiser makes lengths beyond the training lengths harmless), and each segment's tokens
cross-attend to their *own* text: the N texts are laid side by side along the text axis and a cross mask
(:func:`~motionlab.diffusion.segment_cross_mask`) pairs each motion token with its segment's text tokens.
``joint_text="all"`` lets every token see all N texts instead: the appendix's "compound condition" (A.1:
"we concatenate action tokens from successive actions for conditioning"), read literally, one condition made
of every action's words and shared by the whole sequence. Classifier-free guidance is applied jointly: the
unconditional branch replaces every segment's text by ∅ at once.

**Independent phase.** The concatenated sequence is cut back into N segments and they are denoised *as a
batch* (one row per segment, padded to the longest), not with a block-diagonal self-attention mask on the
long sequence. That choice makes ``T_s = T`` (no joint step) *bit-identical* to
:func:`motionlab.diffusion.sample` on the same batch of texts and lengths under the same seed: the same
tensors of the same shapes go through the same calls and draw the same Gumbel noise from the generator.
``T_s = 0`` is fully joint.

**Step grids.** With fast sampling (``num_steps`` < T) the switch must fall on a grid point, so ``T_s`` is
inserted into the grid when it is missing (one extra network call); a jump t → s is joint iff t > T_s.

Several multi-motion *instances* can be sampled at once: pass a list of length lists. Segments are then
numbered flat, instance by instance (the order of the text features).
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field

import torch
from torch import Tensor, nn

from motionlab.diffusion import Transitions, denoise_step, segment_cross_mask, timestep_grid
from motionlab.precision import network_autocast
from motionlab.train.device import model_device

UNIT = 4  # frames per motion token (the VQ-VAE's temporal downsampling)
MAX_ACTIONS = 256  # per instance (M2D2M's Fig. 4 goes up to 256 prompts)
JOINT_TEXTS = ("own", "all")


# ---------------------------------------------------------------------------------------------- layout


@dataclass(frozen=True)
class SegmentLayout:
    """Where each action's tokens sit: instance b holds segments of ``tokens[b][i]`` tokens, back to back.

    Two views of the same tokens are used while sampling:

    * the **canvas** (B, L_c): one row per instance, its segments concatenated, padded to the longest;
    * the **batch** (M, l_max): one row per segment (M = all segments, instance by instance), padded.
    """

    tokens: tuple[tuple[int, ...], ...]
    unit: int = UNIT
    _index: tuple[Tensor, Tensor] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        canvas, batch = [], []
        for m, (b, offset, n) in enumerate(self.placements):
            canvas += [b * self.canvas_length + offset + p for p in range(n)]
            batch += [m * self.max_segment + p for p in range(n)]
        object.__setattr__(self, "_index", (torch.tensor(canvas), torch.tensor(batch)))

    @classmethod
    def from_frames(cls, lengths, unit: int = UNIT, max_actions: int = MAX_ACTIONS) -> SegmentLayout:
        """``lengths``: frames per action, one list (one instance) or a list of lists (a batch of instances).

        Every length must be a positive multiple of ``unit``; an instance holds 1…``max_actions`` actions.
        """
        if isinstance(lengths, Tensor):
            lengths = lengths.tolist()
        if isinstance(lengths, (str, bytes)) or not isinstance(lengths, Sequence) or len(lengths) == 0:
            raise ValueError(
                f"segment_lengths must be a non-empty list of frame counts (or of such lists), got {lengths!r}"
            )
        nested = all(isinstance(x, Sequence) and not isinstance(x, str) for x in lengths)
        instances = [list(x) for x in lengths] if nested else [list(lengths)]
        out = []
        for b, inst in enumerate(instances):
            if not 1 <= len(inst) <= max_actions:
                raise ValueError(f"instance {b} has {len(inst)} actions; expected 1 to max_actions={max_actions}")
            for n in inst:
                if not isinstance(n, numbers.Integral) or isinstance(n, bool) or n < unit or n % unit:
                    raise ValueError(
                        f"segment lengths must be positive multiples of {unit} frames, got {n!r} in instance {b}"
                    )
            out.append(tuple(int(n) // unit for n in inst))
        return cls(tuple(out), unit)

    # --- sizes
    @property
    def n_instances(self) -> int:
        return len(self.tokens)

    @property
    def n_segments(self) -> int:
        return sum(len(t) for t in self.tokens)

    @property
    def flat_tokens(self) -> list[int]:
        """Token count of every segment, instance by instance."""
        return [n for inst in self.tokens for n in inst]

    @property
    def total_tokens(self) -> list[int]:
        return [sum(inst) for inst in self.tokens]

    @property
    def canvas_length(self) -> int:
        return max(self.total_tokens)

    @property
    def max_segment(self) -> int:
        return max(self.flat_tokens)

    @property
    def placements(self) -> list[tuple[int, int, int]]:
        """(instance, token offset in the instance, token count) of every segment."""
        out = []
        for b, inst in enumerate(self.tokens):
            offset = 0
            for n in inst:
                out.append((b, offset, n))
                offset += n
        return out

    def frames(self, b: int) -> list[int]:
        """Frames of each action of instance ``b``."""
        return [n * self.unit for n in self.tokens[b]]

    def boundaries(self, b: int) -> list[int]:
        """First frame of every action but the first, in instance ``b``'s concatenated motion."""
        f = self.frames(b)
        return [sum(f[: i + 1]) for i in range(len(f) - 1)]

    # --- masks and views
    def canvas_padding(self, device=None) -> Tensor:
        """(B, L_c) True beyond each instance's total length."""
        total = torch.tensor(self.total_tokens, device=device)
        return torch.arange(self.canvas_length, device=device)[None, :] >= total[:, None]

    def batch_padding(self, device=None) -> Tensor:
        """(M, l_max) True beyond each segment's length (exactly what ``diffusion.sample`` builds)."""
        lengths = torch.tensor(self.flat_tokens, dtype=torch.long, device=device)
        return torch.arange(self.max_segment, device=device)[None, :] >= lengths[:, None]

    def canvas_segment_ids(self, device=None) -> Tensor:
        """(B, L_c) index of the segment (within its instance) of every canvas token, −1 at padding."""
        ids = torch.full((self.n_instances, self.canvas_length), -1, dtype=torch.long)
        for b, inst in enumerate(self.tokens):
            ids[b, : sum(inst)] = torch.repeat_interleave(torch.arange(len(inst)), torch.tensor(inst))
        return ids.to(device)

    def split(self, canvas: Tensor, fill: int) -> Tensor:
        """Canvas (B, L_c, …) -> batch (M, l_max, …), ``fill`` at padding."""
        c_idx, b_idx = (i.to(canvas.device) for i in self._index)
        rest = canvas.shape[2:]
        out = canvas.new_full((self.n_segments * self.max_segment, *rest), fill)
        out[b_idx] = canvas.reshape(-1, *rest)[c_idx]
        return out.view(self.n_segments, self.max_segment, *rest)

    def merge(self, batch: Tensor, fill: int) -> Tensor:
        """Batch (M, l_max, …) -> canvas (B, L_c, …), ``fill`` at padding."""
        c_idx, b_idx = (i.to(batch.device) for i in self._index)
        rest = batch.shape[2:]
        out = batch.new_full((self.n_instances * self.canvas_length, *rest), fill)
        out[c_idx] = batch.reshape(-1, *rest)[b_idx]
        return out.view(self.n_instances, self.canvas_length, *rest)


def segment_layout(segment_lengths, unit: int = UNIT, max_actions: int = MAX_ACTIONS) -> SegmentLayout:
    """A :class:`SegmentLayout` from frame lengths (passed through if it already is one)."""
    if isinstance(segment_lengths, SegmentLayout):
        return segment_lengths
    return SegmentLayout.from_frames(segment_lengths, unit, max_actions)


@dataclass
class MultiMotionTokens:
    """Sampled token ids of every segment, ``ids`` (M, l_max) with ``pad_id`` beyond each length."""

    ids: Tensor
    layout: SegmentLayout
    pad_id: int = -1

    def segments(self, b: int = 0) -> list[Tensor]:
        """The 1-D id tensors of instance ``b``'s segments, in order."""
        rows = [m for m, (inst, _, _) in enumerate(self.layout.placements) if inst == b]
        return [self.ids[m, :n] for m, n in zip(rows, self.layout.tokens[b], strict=True)]

    def concatenated(self) -> Tensor:
        """(B, L_c) ids of each instance's segments back to back (Algorithm 1, line 11), ``pad_id`` after."""
        return self.layout.merge(self.ids, self.pad_id)

    def boundaries(self, b: int = 0) -> list[int]:
        """Boundary frames of instance ``b`` (the first frame of every action but the first)."""
        return self.layout.boundaries(b)


# ---------------------------------------------------------------------------------------------- inputs


def text_tensors(text, n_segments: int) -> tuple[Tensor, Tensor]:
    """Per-segment text features: a :class:`~motionlab.text.TextFeatures` (or ``(tokens, padding_mask)``)
    -> tokens (M, S, d) and padding mask (M, S), checked against the number of segments M."""
    if hasattr(text, "tokens") and hasattr(text, "padding_mask"):
        tokens, pad = text.tokens, text.padding_mask
    elif isinstance(text, (tuple, list)) and len(text) == 2:
        tokens, pad = text
    else:
        raise ValueError("text must be TextFeatures (or a (tokens, padding_mask) pair), one row per segment")
    if not torch.is_tensor(tokens) or tokens.ndim != 3 or tokens.shape[0] != n_segments:
        raise ValueError(
            f"text tokens must be (M={n_segments}, S, d) — one row per segment — got "
            f"{tuple(getattr(tokens, 'shape', ()))}"
        )
    if pad is None:
        pad = torch.zeros(tokens.shape[:2], dtype=torch.bool, device=tokens.device)
    if tuple(pad.shape) != tuple(tokens.shape[:2]):
        raise ValueError(f"text padding_mask must be {tuple(tokens.shape[:2])}, got {tuple(pad.shape)}")
    return tokens, pad.bool()


def phase_grid(T: int, T_s: int, num_steps: int | None = None, timesteps: Sequence[int] | None = None) -> list[int]:
    """The descending step grid T … 0 of a Two-Phase run, with ``T_s`` on it (inserted if missing)."""
    if not isinstance(T_s, numbers.Integral) or isinstance(T_s, bool) or not 0 <= T_s <= T:
        raise ValueError(f"T_s must be an int in [0, T={T}], got {T_s!r}")
    grid = [int(t) for t in timesteps] if timesteps is not None else timestep_grid(T, num_steps)
    if grid[0] != T or grid[-1] != 0 or any(a <= b for a, b in zip(grid, grid[1:], strict=False)):
        raise ValueError(f"timesteps must descend strictly from T={T} to 0, got {grid}")
    return sorted(set(grid) | {int(T_s)}, reverse=True)


@dataclass
class PhaseCondition:
    """What one phase's network calls see: the text tokens (and their padding), the motion padding and who may
    attend to which text (``cross_mask``, None: every motion token sees every text token)."""

    text: Tensor  # (B, S', d): the joint phase lays an instance's N texts side by side, S' = N_max·S
    text_padding_mask: Tensor  # (B, S'), True at padding (and at absent segments)
    padding_mask: Tensor  # (B, L), True beyond each sequence's length
    cross_mask: Tensor | None  # (B, L, S') or None


def joint_condition(layout: SegmentLayout, tokens: Tensor, text_pad: Tensor, joint_text: str = "own") -> PhaseCondition:
    """Lay each instance's segment texts side by side; with ``"own"`` each token sees only its own text."""
    if joint_text not in JOINT_TEXTS:
        raise ValueError(f"joint_text must be one of {JOINT_TEXTS}, got {joint_text!r}")
    B, M, S, dev = layout.n_instances, layout.n_segments, tokens.shape[1], tokens.device
    n_max = max(len(inst) for inst in layout.tokens)
    text = tokens.new_zeros(B, n_max, S, tokens.shape[2])
    pad = torch.ones(B, n_max, S, dtype=torch.bool, device=dev)
    seg = torch.full((B, n_max, S), -2, dtype=torch.long, device=dev)  # −2 matches no motion token
    m = 0
    for b, inst in enumerate(layout.tokens):
        n = len(inst)
        text[b, :n], pad[b, :n] = tokens[m : m + n], text_pad[m : m + n]
        seg[b, :n] = torch.arange(n, device=dev)[:, None]
        m += n
    assert m == M
    text, pad, seg = text.flatten(1, 2), pad.flatten(1, 2), seg.flatten(1, 2)  # (B, N_max·S, …)
    cross = segment_cross_mask(layout.canvas_segment_ids(dev), seg) if joint_text == "own" else None
    return PhaseCondition(text, pad, layout.canvas_padding(dev), cross)


# ---------------------------------------------------------------------------------------------- sampler


@torch.no_grad()
def tps_loop(
    model: nn.Module,
    transitions: Transitions,
    layout: SegmentLayout,
    grid: Sequence[int],
    T_s: int,
    joint: PhaseCondition | None,
    independent: PhaseCondition,
    **sampling,
) -> Tensor:
    """Algorithm 1 on token ids: z_T (all [MASK]) -> z_0 of every action, (M, l_max) with [MASK] at padding.

    ``grid`` descends from T to 0 with ``T_s`` on it; ``joint`` is the joint phase's condition (None when
    ``T_s = T``), ``independent`` the per-action one; ``sampling`` goes to every :func:`denoise_step`.
    """
    jumps = list(zip(grid[:-1], grid[1:], strict=True))  # (t, s) pairs, T first
    mask = transitions.mask_id

    def step(z: Tensor, t: int, s: int, c: PhaseCondition) -> Tensor:  # one reverse jump z_t -> z_s
        return denoise_step(
            model, transitions, z, t, s, c.text, c.text_padding_mask,
            padding_mask=c.padding_mask, cross_mask=c.cross_mask, **sampling,
        )  # fmt: skip

    # z_T: ONE all-[MASK] sequence per instance, its actions back to back (sum of l_i tokens)
    z = torch.full((layout.n_instances, layout.canvas_length), mask, device=independent.text.device)
    # joint phase, t = T ... T_s+1: tokens attend across the whole sequence, each to its own text
    for t, s in jumps:
        if t > T_s:
            z = step(z, t, s, joint)
    # split at the boundaries: one row per action, padded to the longest
    z = layout.split(z, mask)
    # independent phase, t = T_s ... 1: each action alone, with its own text y^i
    for t, s in jumps:
        if t <= T_s:
            z = step(z, t, s, independent)
    return z


@torch.no_grad()
def two_phase_sample(
    model: nn.Module,
    transitions: Transitions,
    text,
    segment_lengths,
    *,
    T_s: int,
    generator: torch.Generator,
    num_steps: int | None = None,
    timesteps: Sequence[int] | None = None,
    guidance_scale: float = 0.0,
    guidance_on: str = "x0",
    top_p: float | None = None,
    top_k: int | None = None,
    joint_text: str = "own",
    pad_id: int = -1,
) -> MultiMotionTokens:
    """Algorithm 1: joint denoising for t > T_s, then per-segment denoising down to 0.

    Checks the inputs, builds each phase's condition and runs :func:`tps_loop` on the model's device under the
    run's autocast.

    Args:
        text: per-segment text features (M, S, d) + padding (M, S) (:func:`text_tensors`), instance by instance.
        segment_lengths: frames per action (multiples of 4), one list or a list of lists (a batch of instances).
        T_s: steps of the independent phase, in [0, T]: ``T`` = plain independent generation (bit-identical
            to :func:`motionlab.diffusion.sample` on the segment batch), ``0`` = fully joint. M2D2M: 90 of 100.
        num_steps / timesteps: the step grid, as in :func:`motionlab.diffusion.sample` (T_s is added to it).
        guidance_scale: M2D2M's s (2 for multi-motion in the paper); applied jointly in the joint phase.
        joint_text: ``"own"`` (each segment's tokens cross-attend to their own text) or ``"all"``.
    Returns:
        :class:`MultiMotionTokens` (M, l_max) ids on the model's device (the text is moved there);
        ``.concatenated()`` gives each instance's whole sequence.
    """
    layout = segment_layout(segment_lengths)
    tokens, text_pad = text_tensors(text, layout.n_segments)
    grid = phase_grid(transitions.T, T_s, num_steps, timesteps)
    dev = model_device(model, tokens.device)  # generated where the model lives
    tokens, text_pad = tokens.to(dev), text_pad.to(dev)
    independent = PhaseCondition(tokens, text_pad, layout.batch_padding(dev), None)  # (M, l_max): one row per action
    joint = joint_condition(layout, tokens, text_pad, joint_text) if T_s < transitions.T else None
    sampling = dict(
        generator=generator, guidance_scale=guidance_scale, guidance_on=guidance_on, top_p=top_p, top_k=top_k
    )
    with network_autocast(dev):  # posteriors stay fp32 (in_fp32); the network's weights are cast once
        z = tps_loop(model, transitions, layout, grid, T_s, joint, independent, **sampling)
    return MultiMotionTokens(z.masked_fill(independent.padding_mask, pad_id), layout, pad_id)
