"""When the library's input checks may read tensor values back to the host.

Public functions check what they are given: shapes and dtypes always (free: they live on the host), and values
too (no NaN in motion, token ids inside the codebook). A value check reads a tensor back to the host; on a GPU
that waits for every queued kernel, so a check per call can leave the chip idle. Two rules keep the clear
errors where they are cheap and drop the stalls where they are not:

- a value check reads only tensors that already live on the CPU (:func:`values_checked`); on an accelerator an
  id outside the codebook still fails, inside the embedding lookup;
- inside :func:`trusted_values` no value check reads anything: the training loop runs each step inside it,
  because its batches come from data checked once, when the dataset or token sequences were built.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import torch

_TRUSTED: ContextVar[bool] = ContextVar("motionlab_trusted_values", default=False)


def values_checked(tensor: torch.Tensor) -> bool:
    """Whether a value check of ``tensor`` runs: on CPU tensors, outside :func:`trusted_values`."""
    return tensor.device.type == "cpu" and not _TRUSTED.get()


@contextmanager
def trusted_values() -> Iterator[None]:
    """Run a block whose tensors come from already-checked data: value checks read nothing inside it."""
    token = _TRUSTED.set(True)
    try:
        yield
    finally:
        _TRUSTED.reset(token)


__all__ = ["trusted_values", "values_checked"]
