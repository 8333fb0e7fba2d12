"""Learning-rate schedules as pure functions of the step (the nanoGPT way).

Because the rate is recomputed from the step number, a resumed run needs no scheduler state: the step
alone reproduces it. Two shapes cover the book's models:

- warm-up then cosine:     lr(s) = lr_min + ½ (lr_max − lr_min)(1 + cos(π p)),  p = (s − W)/(S − W)
- warm-up then step decay: lr(s) = lr_max · γ^(number of milestones ≤ s)       (torch's MultiStepLR)

Both share a linear warm-up lr(s) = lr_max · (s + 1)/W for s < W (T2M-GPT / MoMask warm up this way).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch

SCHEDULES = ("constant", "cosine", "multistep")


def lr_multiplier(
    step: int,
    *,
    schedule: str = "cosine",
    warmup_steps: int = 0,
    total_steps: int = 1,
    min_lr_ratio: float = 0.1,
    milestones: Sequence[int] = (),
    gamma: float = 0.1,
) -> float:
    """The factor applied to the base learning rate at ``step`` (0-based)."""
    if schedule not in SCHEDULES:
        raise ValueError(f"schedule must be one of {SCHEDULES}, got {schedule!r}")
    if step < warmup_steps:
        return (step + 1) / warmup_steps
    if schedule == "constant":
        return 1.0
    if schedule == "multistep":
        return gamma ** sum(step >= m for m in milestones)
    # cosine from 1 down to min_lr_ratio over the steps after warm-up; flat at the floor afterwards
    span = max(total_steps - warmup_steps, 1)
    progress = min((step - warmup_steps) / span, 1.0)
    return min_lr_ratio + 0.5 * (1.0 - min_lr_ratio) * (1.0 + math.cos(math.pi * progress))


def set_lr(optimizer: torch.optim.Optimizer, lr: float) -> None:
    """Write ``lr`` into every parameter group."""
    for group in optimizer.param_groups:
        group["lr"] = lr
