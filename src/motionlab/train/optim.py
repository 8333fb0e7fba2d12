"""The optimiser every trainer uses: AdamW whose step never reads a tensor back to the host.

torch's unfused AdamW reads each parameter's step counter with ``.item()`` on every update (one host scalar read
per parameter tensor: 34 per step for the smoke RVQ tokenizer, 82 for the DisCoRD decoder). The counter is a
CPU tensor, so on a CPU the read is cheap, but it is still a read per tensor per step, and it is what keeps the
update from being a pure sequence of kernel launches. :class:`AdamW` keeps a Python copy of each counter (read
once, when it is first needed or after a checkpoint is loaded) and otherwise runs torch's own single-tensor
update, operation for operation, so its weights are bit-identical to ``torch.optim.AdamW(foreach=False)``.

With ``fused=True`` (a bf16 run, or any run on CUDA) torch's fused kernel already keeps the counter on the device
and this class simply defers to it.
"""

from __future__ import annotations

import torch
from torch import Tensor


class AdamW(torch.optim.AdamW):
    """``torch.optim.AdamW`` with host-side step counters on its unfused path (same update, same bits).

    Only the options the trainers use are taken over (no ``amsgrad``, ``maximize``, ``capturable``,
    ``differentiable``, ``foreach`` or complex parameters); anything else runs torch's own update.
    """

    def __init__(self, params, **kwargs) -> None:
        super().__init__(params, **kwargs)
        self._counts: dict[Tensor, float] = {}  # parameter -> its step counter, mirrored on the host

    def load_state_dict(self, state_dict) -> None:
        super().load_state_dict(state_dict)
        self._counts.clear()  # read the loaded counters again, once each

    def _own_update(self, group: dict) -> bool:
        unsupported = ("amsgrad", "maximize", "capturable", "differentiable", "foreach", "fused")
        return not any(group.get(name) for name in unsupported) and not any(
            torch.is_complex(p) for p in group["params"]
        )

    @torch.no_grad()
    def step(self, closure=None):
        if not all(self._own_update(group) for group in self.param_groups):
            return super().step(closure)
        loss = None
        if closure is not None:
            with torch.enable_grad():
                loss = closure()
        for group in self.param_groups:
            lr, weight_decay, eps = group["lr"], group["weight_decay"], group["eps"]
            beta1, beta2 = group["betas"]
            for param in group["params"]:
                if param.grad is not None:
                    self._update(param, param.grad, lr, beta1, beta2, weight_decay, eps)
        return loss

    def _update(self, param: Tensor, grad: Tensor, lr, beta1, beta2, weight_decay, eps) -> None:
        if grad.is_sparse:
            raise RuntimeError("AdamW does not support sparse gradients")
        state = self.state[param]
        if len(state) == 0:  # what torch's _init_group creates for an unfused, non-capturable update
            state["step"] = torch.tensor(0.0, dtype=torch.float32)
            state["exp_avg"] = torch.zeros_like(param, memory_format=torch.preserve_format)
            state["exp_avg_sq"] = torch.zeros_like(param, memory_format=torch.preserve_format)
        if param not in self._counts:
            self._counts[param] = float(state["step"])
        state["step"] += 1  # the tensor stays the checkpointed truth
        step = self._counts[param] = self._counts[param] + 1.0
        exp_avg, exp_avg_sq = state["exp_avg"], state["exp_avg_sq"]

        if weight_decay != 0:
            param.mul_(1 - lr * weight_decay)
        exp_avg.lerp_(grad, 1 - beta1)
        exp_avg_sq.mul_(beta2).addcmul_(grad, grad, value=1 - beta2)
        bias_correction1 = 1 - beta1**step
        bias_correction2 = 1 - beta2**step
        step_size = lr / bias_correction1
        denom = (exp_avg_sq.sqrt() / bias_correction2**0.5).add_(eps)
        param.addcdiv_(exp_avg, denom, value=-step_size)


__all__ = ["AdamW"]
