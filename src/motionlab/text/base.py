"""The one interface every text encoder follows.

``encode(list[str])`` returns :class:`TextFeatures`:

- ``tokens`` (B, S, dim): one feature per text token (what the denoiser cross-attends to);
- ``padding_mask`` (B, S) bool: **True at padding** (the convention of torch's ``key_padding_mask``);
- ``sentence`` (B, dim): one pooled feature per text (for retrieval-style uses).

Encoders are ``nn.Module`` s, so ``.to(device)``, ``state_dict()`` and ``train()/eval()`` work as usual.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import NamedTuple

from torch import Tensor


class TextFeatures(NamedTuple):
    tokens: Tensor  # (B, S, dim)
    padding_mask: Tensor  # (B, S) bool, True at padding
    sentence: Tensor  # (B, dim)


class EncoderUnavailableError(RuntimeError):
    """An optional text encoder was asked for but its package or weights are not on this machine."""


class TextEncoder(ABC):
    """Mixin for text encoders: subclasses are ``nn.Module`` s with an attribute ``dim``."""

    dim: int

    @abstractmethod
    def encode(self, texts: Sequence[str]) -> TextFeatures:
        """Encode a batch of texts (see the module docstring for shapes)."""


def check_texts(texts: Sequence[str]) -> list[str]:
    """Validate the ``texts`` argument of :meth:`TextEncoder.encode`: a non-empty sequence of strings."""
    if isinstance(texts, str):
        raise ValueError("texts must be a list of strings, got a single str (wrap it in a list)")
    texts = list(texts)
    if not texts or not all(isinstance(t, str) for t in texts):
        raise ValueError("texts must be a non-empty list of str")
    return texts
