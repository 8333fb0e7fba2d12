"""``torch.compile`` for the trained networks, where it pays.

Compiling fuses a network's many small kernels into fewer, larger ones. On a GPU whose step is bound by kernel
launches that can halve the step (the DisCoRD U-Net at the paper's size on an H200: see chapter 98 and
``book/data/gpu/``); on the CPUs these books are built on it was never measured to pay, and the first step pays
the compile time. One run setting decides (``--compile``, ``$MOTIONLAB_COMPILE``, :mod:`motionlab.settings`):

- ``auto``: compile on CUDA the networks in :data:`COMPILED_ON_CUDA` (those measured faster compiled), with CUDA
  graphs those in :data:`GRAPHED_ON_CUDA`; nothing on a CPU;
- ``on``: compile every trained network, on any device;
- ``graphs``: as ``on``, and on CUDA the launch-bound networks (:data:`LAUNCH_BOUND`) with CUDA graphs too
  (``mode="reduce-overhead"``: a step's thousands of small kernels replayed as one launch);
- ``off``: compile nothing.

CUDA graphs replay fixed shapes, so a graphed network's batches have them: the text-to-motion trainer pads every
batch to the longest crop and the longest caption (:class:`motionlab.diffusion.training.TokenBatches`'s
``fixed_shapes``; the padding is masked, but the noise drawn per position then differs from an unpadded run's), and
the trainer marks each step's start (:attr:`motionlab.train.Trainer.marks_graph_steps`).

Compiling changes no weight or checkpoint (``nn.Module.compile`` compiles the call in place; the state dict keeps
its keys); the compiled kernels are cached under the motionlab cache root, so a second run starts faster. After
training the model is handed back uncompiled (:func:`release_compiled`).
"""

from __future__ import annotations

import os

import torch
from torch import nn

from ..paths import cache_path
from ..settings import COMPILE_CHOICES, env_compile

# Networks whose compiled training step was measured faster on a CUDA GPU (benchmarks/bench_gpu.py records it).
COMPILED_ON_CUDA = frozenset({"discord"})
# Networks whose step stays bound by kernel launches on a GPU: the ``graphs`` setting replays them as CUDA graphs.
LAUNCH_BOUND = frozenset({"denoiser"})
# Of those, the ones ``auto`` graphs: none until bench_gpu.py's "module, compiled, CUDA graphs" shows it pays.
GRAPHED_ON_CUDA: frozenset[str] = frozenset()
PARTS = ("tokenizer", "discord", "denoiser")
DEFAULT, GRAPHED = "default", "reduce-overhead"  # torch.compile modes


def compile_mode(part: str, device: torch.device | str, setting: str | None = None) -> str | None:
    """How ``part`` (one of :data:`PARTS`) is compiled when it trains on ``device`` under ``setting`` (default: the
    run's, ``$MOTIONLAB_COMPILE``): ``None`` (not compiled), ``"default"`` or ``"reduce-overhead"`` (CUDA graphs too,
    only ever on CUDA)."""
    if part not in PARTS:
        raise ValueError(f"part must be one of {PARTS}, got {part!r}")
    setting = env_compile() if setting is None else setting
    if setting not in COMPILE_CHOICES:
        raise ValueError(f"compile setting must be one of {COMPILE_CHOICES}, got {setting!r}")
    on_cuda = torch.device(device).type == "cuda"
    if setting == "off" or (setting == "auto" and not (on_cuda and part in COMPILED_ON_CUDA | GRAPHED_ON_CUDA)):
        return None
    graphed = {"graphs": LAUNCH_BOUND, "auto": GRAPHED_ON_CUDA}.get(setting, frozenset())
    return GRAPHED if on_cuda and part in graphed else DEFAULT


def should_compile(part: str, device: torch.device | str, setting: str | None = None) -> bool:
    """Whether ``part`` is compiled when it trains on ``device`` under ``setting`` (:func:`compile_mode`)."""
    return compile_mode(part, device, setting) is not None


def uses_cuda_graphs(part: str, device: torch.device | str, setting: str | None = None) -> bool:
    """Whether ``part`` trains as CUDA graphs on ``device`` under ``setting`` (its batches need fixed shapes)."""
    return compile_mode(part, device, setting) == GRAPHED


def compile_for_training(modules: list[nn.Module], part: str, device: torch.device | str) -> bool:
    """Compile ``modules`` in place as :func:`compile_mode` says; returns whether it did."""
    mode = compile_mode(part, device)
    if mode is None:
        return False
    os.environ.setdefault("TORCHINDUCTOR_CACHE_DIR", str(cache_path("compiled")))
    for module in modules:
        module.compile(mode=mode)
    return True


def release_compiled(model: nn.Module) -> None:
    """Undo :func:`compile_for_training` on every part of ``model``: the model a training run hands back then runs the
    same eager kernels as a copy loaded from the cache, so its numbers equal the cached model's to the bit."""
    for module in model.modules():
        if getattr(module, "_compiled_call_impl", None) is not None:  # where nn.Module.compile keeps the compiled call
            module._compiled_call_impl = None


__all__ = [
    "COMPILED_ON_CUDA",
    "GRAPHED",
    "GRAPHED_ON_CUDA",
    "LAUNCH_BOUND",
    "PARTS",
    "compile_for_training",
    "compile_mode",
    "release_compiled",
    "should_compile",
    "uses_cuda_graphs",
]
