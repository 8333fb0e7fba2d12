"""A training step never reads a tensor back to the host: the GPU path's no-sync rule, checked on the CPU.

Every ``aten::_local_scalar_dense`` is a value read that, on a GPU, waits for every queued kernel. The trainers of
the book's three trained families read at most one per step that does not log: the RVQ tokenizer's layer dropout
decides in Python how many layers run, so its draw is read, as one value, and nothing else is.
"""

from __future__ import annotations

import pytest
import torch
from torch.profiler import profile
from torch.utils._python_dispatch import TorchDispatchMode

from motionlab.data import load_dataset
from motionlab.tokenizers import build_tokenizer, vq_config
from motionlab.tokenizers.training import tokenizer_trainer
from motionlab.train import get_device

READ = "aten::_local_scalar_dense"


@pytest.fixture(scope="module")
def dataset():
    return load_dataset(None, profile="smoke")


def reads_per_step(trainer, warm_steps: int = 2) -> int:
    """Host scalar reads in one ``train_step``, counted by torch's profiler (after warm-up steps).

    On the CPU torch's AdamW reads each parameter's step counter, a CPU tensor that waits on nothing (the per-tensor
    update in Python, the fused one inside its kernel); on CUDA the fused kernel the trainer takes there keeps them on
    the device. Those reads are not counted: one per parameter with state, exactly, and the rest of the step none.
    """
    for _ in range(warm_steps):  # the first steps initialise codebooks and optimiser state
        trainer.train_step()
    with profile() as prof:
        trainer.train_step()
    counters = len(trainer.optimizer.state) if trainer.device.type == "cpu" else 0
    return sum(e.count for e in prof.key_averages() if e.key == READ) - counters


class ReadsInside(TorchDispatchMode):
    """Counts host scalar reads, and separately those made while ``inside`` is set; none while ``optimizing`` (torch's
    AdamW reads its CPU step counters on the CPU, see :func:`reads_per_step`)."""

    def __init__(self) -> None:
        super().__init__()
        self.total, self.marked, self.inside, self.optimizing = 0, 0, False, False

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        if func is torch.ops.aten._local_scalar_dense.default and not self.optimizing:
            self.total += 1
            self.marked += self.inside
        return func(*args, **(kwargs or {}))


@pytest.mark.parametrize("precision", ["fp32", "bf16"])
def test_the_discord_step_reads_nothing(dataset, bench_gpu, precision):
    trainer, _ = bench_gpu.library_trainer("discord", "smoke", dataset, get_device(), precision)
    assert reads_per_step(trainer) == 0  # 153 before the step stopped reading back


@pytest.mark.parametrize("precision", ["fp32", "bf16"])
def test_the_text_to_motion_step_reads_nothing(dataset, bench_gpu, precision):
    trainer, _ = bench_gpu.library_trainer("t2m", "smoke", dataset, get_device(), precision)
    assert reads_per_step(trainer) == 0  # 112 before


def test_the_tokenizer_steps_read_at_most_the_layer_dropout_draw(dataset, bench_gpu):
    plain = build_tokenizer(vq_config("smoke"))
    assert reads_per_step(tokenizer_trainer(plain, dataset.normalized("train"), progress=False)) == 0  # no dropout

    trainer, _ = bench_gpu.library_trainer("rvq", "smoke", dataset, get_device(), "fp32")
    residual = trainer.model
    assert residual.config.quantize_dropout > 0  # the smoke RVQ drops layers, as MoMask's does
    assert reads_per_step(trainer) <= 1  # 87 before
    counter, draw = ReadsInside(), residual.quantizer.active_layers

    def marked_draw(generator):
        counter.inside = True
        try:
            return draw(generator)
        finally:
            counter.inside = False

    residual.quantizer.active_layers = marked_draw
    optimizer_step = trainer.optimizer.step

    def uncounted_step(*args, **kwargs):
        counter.optimizing = True
        try:
            return optimizer_step(*args, **kwargs)
        finally:
            counter.optimizing = False

    trainer.optimizer.step = uncounted_step
    with counter:
        for _ in range(8):
            trainer.train_step()
    assert counter.marked == 8  # the draw: whether a layer is dropped and how many, read as one value
    assert counter.total == counter.marked
