"""Motion batches for training (random windows) and for evaluation (whole clips, padded).

Tokenizers and the flow decoder train on fixed windows cut from normalised clips. T2M-GPT draws a clip
with probability proportional to its number of windows and then a uniform start; drawing one *flat*
window index uniformly over all windows of all clips is the same distribution, and is what
:class:`WindowDataset` does.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch


def _as_clip(clip, i: int, feature_dim: int | None) -> torch.Tensor:
    t = torch.as_tensor(np.asarray(clip), dtype=torch.float32)
    if t.dim() != 2:
        raise ValueError(f"clips[{i}] must have shape (T, D), got {tuple(t.shape)}")
    if feature_dim is not None and t.shape[1] != feature_dim:
        raise ValueError(f"clips[{i}] has feature dim {t.shape[1]}, expected {feature_dim} like clips[0]")
    return t


class WindowDataset:
    """All length-``window`` windows of ``clips`` (each ``(T, D)``, normalised); shorter clips are skipped.

    A clip of T frames has T − window + 1 windows (MoMask's loader counts T − window, one fewer).
    """

    def __init__(self, clips: Sequence[np.ndarray], window: int = 64):
        if window < 1:
            raise ValueError(f"window must be >= 1, got {window}")
        if len(clips) == 0:
            raise ValueError("clips is empty")
        dim = _as_clip(clips[0], 0, None).shape[1]
        all_clips = [_as_clip(c, i, dim) for i, c in enumerate(clips)]
        self.window = window
        self.feature_dim = dim
        self.clips = [c for c in all_clips if c.shape[0] >= window]
        self.skipped = len(all_clips) - len(self.clips)
        if not self.clips:
            longest = max(c.shape[0] for c in all_clips)
            raise ValueError(f"no clip is at least window={window} frames long (longest has {longest})")
        counts = torch.tensor([c.shape[0] - window + 1 for c in self.clips])
        self.offsets = torch.cumsum(counts, 0) - counts  # first flat index of each clip's windows

    def __len__(self) -> int:
        return int(self.offsets[-1]) + self.clips[-1].shape[0] - self.window + 1

    def __getitem__(self, index: int) -> torch.Tensor:
        """The window with flat index ``index``: ``(window, D)``."""
        if not 0 <= index < len(self):
            raise IndexError(f"window index {index} out of range [0, {len(self)})")
        clip = int(torch.searchsorted(self.offsets, torch.tensor(index), right=True)) - 1
        start = index - int(self.offsets[clip])
        return self.clips[clip][start : start + self.window]

    def sample(self, batch_size: int, generator: torch.Generator) -> torch.Tensor:
        """``batch_size`` windows drawn uniformly (with replacement) over all windows: ``(B, window, D)``."""
        idx = torch.randint(len(self), (batch_size,), generator=generator)
        return torch.stack([self[int(i)] for i in idx])

    def batches(self, batch_size: int):
        """A ``batch_fn(step, generator)`` for :class:`motionlab.train.Trainer`."""
        if batch_size < 1:
            raise ValueError(f"batch_size must be >= 1, got {batch_size}")
        return lambda step, generator: self.sample(batch_size, generator)


def crop_length(length: int, unit: int = 4) -> int:
    """Largest multiple of ``unit`` not above ``length`` (HumanML3D floors lengths to multiples of 4)."""
    return (length // unit) * unit


def collate_clips(clips: Sequence[np.ndarray], unit: int = 4) -> tuple[torch.Tensor, torch.Tensor]:
    """Whole clips for evaluation: each cropped to a multiple of ``unit`` and zero-padded at the end.

    Returns ``motion (B, T_max, D)`` and ``lengths (B,)``; frames at or after ``lengths[b]`` are padding.
    """
    if len(clips) == 0:
        raise ValueError("clips is empty")
    dim = _as_clip(clips[0], 0, None).shape[1]
    tensors = [_as_clip(c, i, dim) for i, c in enumerate(clips)]
    lengths = [crop_length(t.shape[0], unit) for t in tensors]
    if min(lengths) == 0:
        bad = lengths.index(0)
        raise ValueError(f"clips[{bad}] has {tensors[bad].shape[0]} frames, fewer than unit={unit}")
    out = torch.zeros(len(tensors), max(lengths), dim)
    for b, (t, n) in enumerate(zip(tensors, lengths)):
        out[b, :n] = t[:n]
    return out, torch.tensor(lengths)
