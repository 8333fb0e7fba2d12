"""Exponential moving average of model weights.

θ_ema ← d · θ_ema + (1 − d) · θ after every optimiser step. Averaged weights usually sample and
evaluate better than the last iterate; floating-point buffers are averaged the same way, integer and
boolean buffers (counters, flags) are copied.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import torch
from torch import nn


class EMA:
    """Shadow copy of ``model``'s state, updated with :meth:`update` and swapped in with :meth:`apply_to`."""

    def __init__(self, model: nn.Module, decay: float = 0.999):
        if not 0.0 <= decay < 1.0:
            raise ValueError(f"decay must be in [0, 1), got {decay}")
        self.decay = decay
        self.shadow = {k: v.detach().clone() for k, v in model.state_dict().items()}

    @torch.no_grad()
    def update(self, model: nn.Module) -> None:
        """One averaging step towards ``model``'s weights; the averages follow the model to its device."""
        averaged, values, copied, sources = [], [], [], []
        for name, value in model.state_dict().items():
            if self.shadow[name].device != value.device:  # the model was moved after this EMA was made
                self.shadow[name] = self.shadow[name].to(value.device)
            if value.is_floating_point():
                averaged.append(self.shadow[name])
                values.append(value.detach())
            else:
                copied.append(self.shadow[name])
                sources.append(value)
        # one multi-tensor call each (a few GPU launches instead of one per tensor); per tensor the same
        # avg + (1 − d)(value − avg) as avg.lerp_(value, 1 − d)
        if averaged:
            torch._foreach_lerp_(averaged, values, 1.0 - self.decay)
        if copied:
            torch._foreach_copy_(copied, sources)

    @torch.no_grad()
    def copy_to(self, model: nn.Module) -> None:
        """Overwrite ``model``'s weights with the averages."""
        model.load_state_dict(self.shadow)

    @contextmanager
    def apply_to(self, model: nn.Module) -> Iterator[nn.Module]:
        """Temporarily evaluate ``model`` with averaged weights; the training weights come back afterwards."""
        backup = {k: v.detach().clone() for k, v in model.state_dict().items()}
        self.copy_to(model)
        try:
            yield model
        finally:
            model.load_state_dict(backup)

    def state_dict(self) -> dict[str, torch.Tensor]:
        return dict(self.shadow)

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        if set(state) != set(self.shadow):
            raise ValueError("EMA state does not match the model's parameters and buffers")
        for name, value in state.items():
            self.shadow[name].copy_(value)
