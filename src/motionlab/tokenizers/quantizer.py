"""Vector quantisation with an EMA codebook and dead-code reset (``QuantizeEMAReset`` of T2M-GPT / MoMask).

A latent vector x is replaced by its nearest code c_k, k = argmin_j ‖x − c_j‖². The codebook is not
learned by gradient descent: each code tracks the running mean of the vectors assigned to it,

    N_k ← μ N_k + (1 − μ) n_k          (n_k: how many vectors chose code k in this batch)
    S_k ← μ S_k + (1 − μ) Σ_{i→k} x_i
    c_k ← S_k / N_k                    (μ = 0.99)

and a code whose running count N_k falls below a threshold ("dead") is re-initialised to a random
current encoder output, so that every code stays in use. Gradients skip the non-differentiable lookup
(straight-through: forward c_k, backward identity), and the commitment loss ‖x − sg(c_k)‖² pulls the
encoder towards its codes.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from ..precision import in_fp32


@dataclass
class QuantizeOutput:
    quantized: torch.Tensor  # (..., C) codes in the forward pass, identity gradient to the input
    codes: torch.Tensor  # (..., C) the exact codebook rows (no gradient)
    ids: torch.Tensor  # (...) int64 code indices
    commit_loss: torch.Tensor  # scalar MSE(x, sg(codes))
    perplexity: torch.Tensor  # scalar exp(entropy of this batch's code histogram), in [1, min(K, N)]
    usage: torch.Tensor  # scalar fraction of codes chosen at least once in this batch


def perplexity_of(ids: torch.Tensor, codebook_size: int) -> torch.Tensor:
    """exp(−Σ p_k log p_k) of the histogram of ``ids``: 1 if one code is used, K if all are used equally."""
    p = torch.bincount(ids.flatten(), minlength=codebook_size).float() / ids.numel()
    return torch.exp(-(p * torch.log(p.clamp_min(1e-12))).sum())


def fallback_generator(module: nn.Module, device: torch.device) -> torch.Generator:
    """A module's own generator (seeded by ``module.seed``) for calls that pass none, e.g. ``model(x)``."""
    gen = getattr(module, "_generator", None)
    if gen is None or gen.device != device:
        gen = torch.Generator(device=device).manual_seed(module.seed)
        module._generator = gen
    return gen


class QuantizerEMAReset(nn.Module):
    """One codebook of ``codebook_size`` codes of ``code_dim`` dimensions, updated by EMA with dead-code reset."""

    def __init__(
        self,
        codebook_size: int,
        code_dim: int,
        decay: float = 0.99,
        reset_threshold: float = 1.0,
        gumbel_temperature: float = 0.0,
        seed: int = 0,
    ):
        super().__init__()
        if codebook_size < 2 or code_dim < 1:
            raise ValueError(f"need codebook_size >= 2 and code_dim >= 1, got {codebook_size}, {code_dim}")
        if not 0.0 <= decay < 1.0:
            raise ValueError(f"decay must be in [0, 1), got {decay}")
        self.codebook_size, self.code_dim = codebook_size, code_dim
        self.decay, self.reset_threshold = decay, reset_threshold
        self.gumbel_temperature = gumbel_temperature  # > 0: sample codes while training (MoMask uses 0.5)
        self.seed = seed
        # Random rows until the first training batch replaces them, so an untrained model still has distinct codes.
        init = torch.randn(codebook_size, code_dim, generator=torch.Generator().manual_seed(seed))
        self.register_buffer("codebook", init)  # (K, C)
        self.register_buffer("code_sum", init.clone())  # (K, C) EMA of summed assigned vectors
        self.register_buffer("code_count", torch.ones(codebook_size))  # (K,) EMA of assignment counts
        self.register_buffer("initialized", torch.tensor(False))
        self._initialized_on_host: bool | None = None  # None: not read yet (read once, at the first training step)

    # -- pure lookups (no state change) -------------------------------------------------------------------------
    def distances(self, x: torch.Tensor) -> torch.Tensor:
        """Squared distances ‖x‖² − 2 x·c + ‖c‖²: ``(N, C)`` → ``(N, K)``, on the codebook's device."""
        c = self.codebook
        x = x.to(c.device)
        return x.pow(2).sum(-1, keepdim=True) - 2 * x @ c.t() + c.pow(2).sum(-1)[None, :]

    def quantize(self, x: torch.Tensor) -> torch.Tensor:
        """Nearest-code indices (deterministic argmin): ``(..., C)`` → ``(...)``."""
        flat = x.reshape(-1, self.code_dim)
        return self.distances(flat).argmin(-1).reshape(x.shape[:-1])

    def lookup(self, ids: torch.Tensor) -> torch.Tensor:
        """Code vectors for indices: ``(...)`` → ``(..., C)``, on the codebook's device."""
        return F.embedding(ids.to(self.codebook.device), self.codebook)

    # -- training-time state updates --------------------------------------------------------------------------
    @torch.no_grad()
    def _random_rows(self, x: torch.Tensor, n: int, generator: torch.Generator) -> torch.Tensor:
        """``n`` rows of ``x`` (N, C) picked at random: distinct when N ≥ n, else repeated with small noise.

        Drawn on ``generator``'s device (a CPU generator gives the same rows whatever device ``x`` is on)."""
        draw_on = generator.device
        if x.shape[0] >= n:
            return x[torch.randperm(x.shape[0], generator=generator, device=draw_on)[:n].to(x.device)]
        rows = x[torch.randint(x.shape[0], (n,), generator=generator, device=draw_on).to(x.device)]
        noise = torch.randn(rows.shape, generator=generator, device=draw_on).to(x.device)
        return rows + noise * 0.01 / self.code_dim**0.5  # jitter so repeated rows are distinct codes

    @torch.no_grad()
    def init_codebook(self, x: torch.Tensor, generator: torch.Generator) -> None:
        """Initialise every code from the encoder outputs ``x (N, C)`` of the first training batch."""
        rows = self._random_rows(x, self.codebook_size, generator)
        self.codebook.copy_(rows)
        self.code_sum.copy_(rows)
        self.code_count.fill_(1.0)
        self.initialized.fill_(True)
        self._initialized_on_host = True

    def _is_initialized(self) -> bool:
        """The ``initialized`` flag, read from the buffer once and then remembered on the host."""
        if self._initialized_on_host is None:
            self._initialized_on_host = bool(self.initialized)
        return self._initialized_on_host

    def _load_from_state_dict(self, *args, **kwargs) -> None:
        super()._load_from_state_dict(*args, **kwargs)
        self._initialized_on_host = None  # the loaded flag is read again at the next training step

    @torch.no_grad()
    def ema_update(self, x: torch.Tensor, ids: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
        """EMA step from ``x (N, C)`` assigned to ``ids (N,)``, then dead-code reset; returns how many codes were
        reset (a 0-d tensor on the codebook's device: reading it waits for the device)."""
        # one-hot rows by scatter: F.one_hot's range check would read ids back to the host at every step
        onehot = torch.zeros(ids.shape[0], self.codebook_size, dtype=x.dtype, device=x.device)
        onehot.scatter_(1, ids[:, None], 1.0)  # (N, K)
        self.code_count.mul_(self.decay).add_(onehot.sum(0), alpha=1 - self.decay)
        self.code_sum.mul_(self.decay).add_(onehot.t() @ x, alpha=1 - self.decay)
        alive = self.code_count >= self.reset_threshold  # (K,)
        means = self.code_sum / self.code_count.clamp_min(1e-12)[:, None]
        fresh = self._random_rows(x, self.codebook_size, generator)
        self.codebook.copy_(torch.where(alive[:, None], means, fresh))
        return (~alive).sum()

    # -- the layer ----------------------------------------------------------------------------------------------
    @in_fp32  # nearest-code search and codebook EMA stay exact under bf16 autocast
    def forward(self, x: torch.Tensor, generator: torch.Generator | None = None) -> QuantizeOutput:
        """Quantise ``x (..., C)``. In training mode this also initialises / EMA-updates / resets the codebook."""
        flat = x.reshape(-1, self.code_dim)  # (N, C)
        if self.training:
            gen = generator if generator is not None else fallback_generator(self, x.device)
            detached = flat.detach()
            if not self._is_initialized():
                self.init_codebook(detached, gen)
            if self.gumbel_temperature > 0:
                # Gumbel-max: argmax(−d/τ + g), g ~ Gumbel(0, 1), samples k ∝ exp(−d_k/τ)
                u = torch.rand(flat.shape[0], self.codebook_size, generator=gen, device=gen.device).to(x.device)
                gumbel = -torch.log(-torch.log(u.clamp(1e-10, 1.0 - 1e-7)))
                ids = (-self.distances(detached) / self.gumbel_temperature + gumbel).argmax(-1)
            else:
                ids = self.distances(detached).argmin(-1)
            codes = self.lookup(ids)  # code vectors before the update, as in the reference
            self.ema_update(detached, ids, gen)
        else:
            ids = self.distances(flat.detach()).argmin(-1)
            codes = self.lookup(ids)
        codes = codes.detach()
        commit = F.mse_loss(flat, codes)  # ‖x − sg(c)‖²: only the encoder moves
        quantized = flat + (codes - flat).detach()  # straight-through estimator
        shape = x.shape[:-1]
        return QuantizeOutput(
            quantized=quantized.reshape(x.shape),
            codes=codes.reshape(x.shape),
            ids=ids.reshape(shape),
            commit_loss=commit,
            perplexity=perplexity_of(ids, self.codebook_size),
            usage=(torch.bincount(ids, minlength=self.codebook_size) > 0).float().mean(),
        )
