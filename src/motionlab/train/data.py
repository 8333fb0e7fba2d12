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

    A clip of T frames has T − window + 1 windows (MoMask's loader counts T − window, one fewer). The kept clips
    are stored end to end in one ``(F, D)`` tensor, ``frames``, with the first frame of every window in
    ``window_starts``, so a batch of windows is one gather; :meth:`to` moves both to a device once (the trainer
    does this for a GPU run), after which batches are built there.
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
        kept = [c for c in all_clips if c.shape[0] >= window]
        self.skipped = len(all_clips) - len(kept)
        if not kept:
            longest = max(c.shape[0] for c in all_clips)
            raise ValueError(f"no clip is at least window={window} frames long (longest has {longest})")
        self.frames = torch.cat(kept)  # (F, D): every kept clip, end to end
        if not torch.isfinite(self.frames).all():  # checked once here, so training steps need not
            raise ValueError("clips contain NaN or inf values")
        lengths = torch.tensor([c.shape[0] for c in kept])
        counts = lengths - window + 1
        self.offsets = torch.cumsum(counts, 0) - counts  # first flat window index of each clip
        first_frame = torch.cumsum(lengths, 0) - lengths  # first row of each clip in `frames`
        # window i of clip c starts at first_frame[c] + (i − offsets[c])
        self._length = int(counts.sum())
        self.window_starts = torch.repeat_interleave(first_frame - self.offsets, counts) + torch.arange(self._length)
        self._clip_lengths = lengths.tolist()
        self._steps = torch.arange(window)  # (W,) frame offsets inside a window

    @property
    def clips(self) -> list[torch.Tensor]:
        """The kept clips, each a ``(T, D)`` view of ``frames``."""
        return list(torch.split(self.frames, self._clip_lengths))

    @property
    def device(self) -> torch.device:
        return self.frames.device

    def to(self, device: str | torch.device) -> WindowDataset:
        """Keep the frames and the window table on ``device`` (in place); returns ``self``."""
        self.frames, self.window_starts, self._steps = (
            t.to(device) for t in (self.frames, self.window_starts, self._steps)
        )
        return self

    def __len__(self) -> int:
        return self._length

    def __getitem__(self, index: int) -> torch.Tensor:
        """The window with flat index ``index``: ``(window, D)``."""
        if not 0 <= index < len(self):
            raise IndexError(f"window index {index} out of range [0, {len(self)})")
        start = int(self.window_starts[index])
        return self.frames[start : start + self.window]

    def sample(self, batch_size: int, generator: torch.Generator) -> torch.Tensor:
        """``batch_size`` windows drawn uniformly (with replacement) over all windows: ``(B, window, D)`` on
        :attr:`device`. The indices come from ``generator`` (on its own device), the gather runs on the frames'."""
        idx = torch.randint(len(self), (batch_size,), generator=generator, device=generator.device)
        rows = (
            self.window_starts[idx.to(self.device, non_blocking=True)][:, None] + self._steps
        )  # (B, W) rows of `frames`
        return self.frames[rows]

    def batches(self, batch_size: int) -> WindowBatches:
        """A ``batch_fn(step, generator)`` for :class:`motionlab.train.Trainer`."""
        return WindowBatches(self, batch_size)


class WindowBatches:
    """``batch_fn(step, generator) -> (B, window, D)`` windows of a :class:`WindowDataset`; ``to(device)`` moves
    the dataset, which is how the trainer gets the batches built on its device."""

    def __init__(self, windows: WindowDataset, batch_size: int):
        if batch_size < 1:
            raise ValueError(f"batch_size must be >= 1, got {batch_size}")
        self.windows, self.batch_size = windows, batch_size

    def to(self, device: str | torch.device) -> WindowBatches:
        self.windows.to(device)
        return self

    def __call__(self, step: int, generator: torch.Generator) -> torch.Tensor:
        return self.windows.sample(self.batch_size, generator)


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
