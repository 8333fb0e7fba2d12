"""``torch.compile`` for the trained networks, where it pays.

Compiling fuses a network's many small kernels into fewer, larger ones. On a GPU whose step is bound by kernel
launches that can halve the step (the DisCoRD U-Net at the paper's size on an H200: see chapter 98 and
``book/data/gpu/``); on the CPUs these books are built on it was never measured to pay, and the first step pays
the compile time. One run setting decides (``--compile``, ``$MOTIONLAB_COMPILE``, :mod:`motionlab.settings`):

- ``auto``: compile on CUDA the networks in :data:`COMPILED_ON_CUDA` (those measured faster compiled), nothing
  on a CPU;
- ``on``: compile every trained network, on any device;
- ``off``: compile nothing.

Compiling changes no weight or checkpoint (``nn.Module.compile`` compiles the call in place; the state dict keeps
its keys); the compiled kernels are cached under the motionlab cache root, so a second run starts faster. After
training the model is handed back uncompiled (:func:`release_compiled`).
"""

from __future__ import annotations

import os

import torch
from torch import nn

from ..paths import cache_path
from ..settings import env_compile

# Networks whose compiled training step was measured faster on a CUDA GPU (benchmarks/bench_gpu.py records it).
COMPILED_ON_CUDA = frozenset({"discord"})
PARTS = ("tokenizer", "discord", "denoiser")


def should_compile(part: str, device: torch.device | str, setting: str | None = None) -> bool:
    """Whether ``part`` (one of :data:`PARTS`) is compiled when it trains on ``device`` under ``setting``
    (default: the run's, ``$MOTIONLAB_COMPILE``)."""
    if part not in PARTS:
        raise ValueError(f"part must be one of {PARTS}, got {part!r}")
    setting = env_compile() if setting is None else setting
    if setting == "off":
        return False
    if setting == "on":
        return True
    if setting != "auto":
        raise ValueError(f"compile setting must be auto, on or off, got {setting!r}")
    return torch.device(device).type == "cuda" and part in COMPILED_ON_CUDA


def compile_for_training(modules: list[nn.Module], part: str, device: torch.device | str) -> bool:
    """Compile ``modules`` in place when :func:`should_compile` says so; returns whether it did."""
    if not should_compile(part, device):
        return False
    os.environ.setdefault("TORCHINDUCTOR_CACHE_DIR", str(cache_path("compiled")))
    for module in modules:
        module.compile()
    return True


def release_compiled(model: nn.Module) -> None:
    """Undo :func:`compile_for_training` on every part of ``model``: the model a training run hands back then runs the
    same eager kernels as a copy loaded from the cache, so its numbers equal the cached model's to the bit."""
    for module in model.modules():
        if getattr(module, "_compiled_call_impl", None) is not None:  # where nn.Module.compile keeps the compiled call
            module._compiled_call_impl = None


__all__ = ["COMPILED_ON_CUDA", "PARTS", "compile_for_training", "release_compiled", "should_compile"]
