"""Where tensors live and where randomness comes from.

Every model in the book trains through :mod:`motionlab.train`; this module decides the device and turns
one integer seed into the explicit generators the rest of the code draws from.
"""

from __future__ import annotations

import os
import random
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import torch


def get_device(device: str | torch.device | None = None) -> torch.device:
    """The device to train on: ``device`` if given, else ``$MOTIONLAB_DEVICE``, else CUDA when present, else CPU."""
    choice = device if device is not None else os.environ.get("MOTIONLAB_DEVICE")
    if choice is None or str(choice).strip() == "":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        dev = torch.device(choice)
    except RuntimeError as err:
        raise ValueError(f"device must be a torch device string such as 'cpu' or 'cuda:0', got {choice!r}") from err
    if dev.type not in ("cpu", "cuda"):  # the library's kernels, precisions and tests cover these two
        raise ValueError(f"device must be 'cpu' or 'cuda' (optionally 'cuda:N'), got {choice!r}")
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device {choice!r} was requested but CUDA is not available on this machine")
    return dev


def device_name(device: torch.device) -> str:
    """What a record calls the hardware behind ``device``: the GPU's name on CUDA, else the CPU's model and flags."""
    if device.type == "cuda":
        return torch.cuda.get_device_name(device)
    from ..precision import read_cpu_info

    return read_cpu_info().summary


def seed_everything(seed: int) -> torch.Generator:
    """Seed Python, NumPy and torch's global RNGs and return a fresh CPU ``torch.Generator`` seeded with ``seed``.

    Library code draws only from explicit generators; the global seeds are for third-party code
    (e.g. ``nn.Dropout`` or default weight initialisation) that reads the global state.
    """
    if not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    random.seed(seed)
    np.random.seed(seed % 2**32)  # noqa: NPY002 -- the legacy global state is what we must seed
    torch.manual_seed(seed)  # also seeds every CUDA device
    return torch.Generator().manual_seed(seed)


@contextmanager
def seeded(seed: int) -> Iterator[None]:
    """Run a block (typically a model constructor) with torch's global RNG seeded, then restore the old state.

    ``nn.Module`` constructors initialise weights from the global RNG; wrapping them makes a model a pure
    function of its config without disturbing anyone else's random stream.
    """
    devices = list(range(torch.cuda.device_count())) if torch.cuda.is_available() else []
    with torch.random.fork_rng(devices=devices):
        torch.manual_seed(seed)
        yield


def model_device(model: torch.nn.Module, default: torch.device) -> torch.device:
    """Where ``model``'s weights live (``default`` for a model without any, e.g. a test stand-in): where the public
    functions that run it move their tensor arguments."""
    for tensor in (*model.parameters(), *model.buffers()):
        return tensor.device
    return default


def to_device(batch, device: torch.device):
    """Move a tensor, or the tensors inside nested dicts/lists/tuples, to ``device``."""
    if isinstance(batch, torch.Tensor):
        return batch.to(device, non_blocking=True)
    if isinstance(batch, dict):
        return {k: to_device(v, device) for k, v in batch.items()}
    if isinstance(batch, (list, tuple)):
        moved = [to_device(v, device) for v in batch]
        return type(batch)(*moved) if hasattr(batch, "_fields") else type(batch)(moved)
    return batch
