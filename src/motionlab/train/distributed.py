"""Data-parallel training across processes (``torchrun --nproc_per_node N``), on CPU (gloo) or GPUs (nccl).

The scheme is DistributedDataParallel's arithmetic, written out so a reader can see all of it:

1. every rank draws the *same global batch* (the data generator is seeded identically on all ranks);
2. each rank keeps its own contiguous shard of it (the role of a distributed sampler);
3. after ``backward`` the gradients are averaged across ranks with one all-reduce;
4. every rank applies the same optimiser step, so the weights stay identical everywhere.

With a loss that is a mean over batch elements and equal shards, N ranks compute exactly the update of one
process on the global batch (up to float summation order). Noise (flow-matching noise, diffusion steps) is
drawn per rank from its own stream, so noisy losses match a single process in distribution, not bit for bit.
Only rank 0 writes checkpoints and shows progress; every rank resumes from the same checkpoint.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import torch
import torch.distributed as dist


@dataclass(frozen=True)
class DistributedContext:
    """Where this process stands in a data-parallel job (a single process is rank 0 of 1)."""

    rank: int = 0
    world_size: int = 1
    local_rank: int = 0

    @property
    def enabled(self) -> bool:
        return self.world_size > 1

    @property
    def is_main(self) -> bool:
        return self.rank == 0


def current_context() -> DistributedContext:
    """The context of an already initialised process group, else a single process."""
    if dist.is_available() and dist.is_initialized():
        local = int(os.environ.get("LOCAL_RANK", dist.get_rank()))
        return DistributedContext(dist.get_rank(), dist.get_world_size(), local)
    return DistributedContext()


def rank_device(ctx: DistributedContext, device: str | torch.device | None = None) -> str | torch.device | None:
    """The device a process trains on: ``device``, else ``$MOTIONLAB_DEVICE``, else None (the default choice).

    Under torchrun each rank takes its own GPU: a bare ``cuda``, or no choice on a machine with CUDA, becomes
    ``cuda:<local rank>``.
    """
    choice = device if device is not None else (os.environ.get("MOTIONLAB_DEVICE") or None)
    if not ctx.enabled:
        return choice
    if choice is None:
        choice = "cuda" if torch.cuda.is_available() else "cpu"
    return f"cuda:{ctx.local_rank}" if str(choice) == "cuda" else choice


def check_gpus_for_ranks(local_world_size: int) -> None:
    """Refuse, in one line, more ranks on this machine than it has GPUs (each rank needs a GPU of its own)."""
    gpus = torch.cuda.device_count()
    if local_world_size > gpus:
        raise ValueError(
            f"torchrun started {local_world_size} processes on this machine but it has {gpus} GPU(s): "
            f"use --nproc_per_node {max(gpus, 1)}, or set MOTIONLAB_DEVICE=cpu to run the ranks on the CPU (gloo)"
        )


def init_distributed(backend: str | None = None, device: str | None = None) -> DistributedContext:
    """Join the process group torchrun describes in the environment (``WORLD_SIZE``, ``RANK``, ...).

    Without those variables (a plain ``python`` run) nothing is initialised and a single-process context is
    returned, so the same script runs both ways. Ranks on GPUs (``device``, ``$MOTIONLAB_DEVICE``, else CUDA when
    present) join with nccl, one GPU each; ranks on the CPU with gloo. ``backend`` overrides that choice.
    """
    if dist.is_initialized():
        return current_context()
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        return DistributedContext()
    local_rank = int(os.environ.get("LOCAL_RANK", "0"))
    ranks_here = int(os.environ.get("LOCAL_WORLD_SIZE", world))
    target = str(rank_device(DistributedContext(0, world, local_rank), device))
    on_gpus = target.startswith("cuda")
    if on_gpus:
        check_gpus_for_ranks(ranks_here)
    backend = backend or ("nccl" if on_gpus else "gloo")
    if backend == "nccl":
        torch.cuda.set_device(local_rank)
    dist.init_process_group(backend=backend)
    return current_context()


def shard_batch(batch, ctx: DistributedContext):
    """This rank's contiguous slice of every tensor (along dim 0) in a nested batch."""
    if not ctx.enabled:
        return batch
    if isinstance(batch, torch.Tensor):
        n = batch.shape[0]
        if n % ctx.world_size:
            raise ValueError(f"global batch of {n} does not split evenly over {ctx.world_size} processes")
        size = n // ctx.world_size
        return batch[ctx.rank * size : (ctx.rank + 1) * size]
    if isinstance(batch, dict):
        return {k: shard_batch(v, ctx) for k, v in batch.items()}
    if isinstance(batch, (list, tuple)):
        parts = [shard_batch(v, ctx) for v in batch]
        return type(batch)(*parts) if hasattr(batch, "_fields") else type(batch)(parts)
    return batch


def average_gradients(parameters, ctx: DistributedContext) -> None:
    """Replace each gradient by its mean over ranks (one flattened all-reduce)."""
    if not ctx.enabled:
        return
    grads = [p.grad for p in parameters if p.grad is not None]
    if not grads:
        return
    flat = torch.cat([g.reshape(-1) for g in grads])
    dist.all_reduce(flat, op=dist.ReduceOp.SUM)
    flat /= ctx.world_size
    offset = 0
    for g in grads:
        g.copy_(flat[offset : offset + g.numel()].view_as(g))
        offset += g.numel()


def average_scalars(values: dict[str, float], ctx: DistributedContext) -> dict[str, float]:
    """Mean of logged scalars over ranks (what the rank-0 progress bar and history show)."""
    if not ctx.enabled or not values:
        return values
    keys = sorted(values)
    # nccl reduces only GPU tensors: the few numbers travel through this rank's GPU there
    device = f"cuda:{ctx.local_rank}" if dist.get_backend() == "nccl" else "cpu"
    t = torch.tensor([values[k] for k in keys], dtype=torch.float64, device=device)
    dist.all_reduce(t, op=dist.ReduceOp.SUM)
    return {k: float(v) / ctx.world_size for k, v in zip(keys, t.tolist())}


def barrier(ctx: DistributedContext) -> None:
    if ctx.enabled:
        dist.barrier()


def gather_generator_states(gen: torch.Generator, ctx: DistributedContext) -> list[torch.Tensor]:
    """Every rank's state of a generator, on every rank (so rank 0 can checkpoint all of them)."""
    state = gen.get_state()
    if not ctx.enabled:
        return [state]
    states: list = [None] * ctx.world_size
    dist.all_gather_object(states, state)
    return states
