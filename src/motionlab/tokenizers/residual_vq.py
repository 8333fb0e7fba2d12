"""Residual vector quantisation (MoMask): R codebooks, each quantising what the previous ones missed.

    r_0 = z,   q_k = VQ_k(r_k),   r_{k+1} = r_k − sg(q_k),   z_q = Σ_k q_k

Layer 0 carries the coarse motion, later layers add detail, so decoding with only the first few layers
still gives a (coarser) motion. Quantize dropout trains exactly that: with probability p a batch keeps
only layers 0..s for a random s, and the skipped layers report index −1 ("no code", embedded as 0).
"""

from __future__ import annotations

import torch
from torch import nn

from ..precision import in_fp32
from .quantizer import QuantizeOutput, QuantizerEMAReset, fallback_generator


class ResidualVQ(nn.Module):
    """``num_layers`` :class:`QuantizerEMAReset` codebooks (not shared) applied to successive residuals."""

    def __init__(
        self,
        num_layers: int,
        codebook_size: int,
        code_dim: int,
        quantize_dropout: float = 0.2,
        decay: float = 0.99,
        reset_threshold: float = 1.0,
        gumbel_temperature: float = 0.0,
        seed: int = 0,
    ):
        super().__init__()
        if num_layers < 1:
            raise ValueError(f"num_layers must be >= 1, got {num_layers}")
        if not 0.0 <= quantize_dropout <= 1.0:
            raise ValueError(f"quantize_dropout must be a probability, got {quantize_dropout}")
        self.num_layers, self.codebook_size, self.code_dim = num_layers, codebook_size, code_dim
        self.quantize_dropout, self.seed = quantize_dropout, seed
        self.layers = nn.ModuleList(
            QuantizerEMAReset(codebook_size, code_dim, decay, reset_threshold, gumbel_temperature, seed=seed + k)
            for k in range(num_layers)
        )

    def active_layers(self, generator: torch.Generator) -> int:
        """How many layers run in this training batch: all, or 1 + s with s ~ U{0..R−1} with prob. p.

        The rule draws the depth only when a layer is dropped. Both draws are made and read back as one
        value (0: nothing dropped), because on a GPU every read waits for the queued kernels; when nothing
        is dropped the depth draw is put back, so ``generator`` advances exactly as under the rule.
        """
        if self.quantize_dropout == 0 or self.num_layers == 1:
            return self.num_layers
        device = generator.device
        dropped = torch.rand((), generator=generator, device=device) < self.quantize_dropout
        before_depth = generator.get_state()
        depth = torch.randint(1, self.num_layers + 1, (), generator=generator, device=device)
        chosen = int(torch.where(dropped, depth, 0))  # the step's one host read
        if chosen == 0:
            generator.set_state(before_depth)
            return self.num_layers
        return chosen

    @in_fp32  # residuals, nearest codes and codebook EMA stay exact under bf16 autocast
    def forward(self, z: torch.Tensor, generator: torch.Generator | None = None) -> QuantizeOutput:
        """Quantise ``z (..., C)``; ``ids`` is ``(..., R)`` with −1 for layers dropped in this batch.

        ``perplexity`` and ``usage`` are per layer ``(R,)`` (0 for dropped layers); ``commit_loss`` is
        averaged over the layers that ran.
        """
        gen = generator if generator is not None else fallback_generator(self, z.device)
        active = self.active_layers(gen) if self.training else self.num_layers
        residual = z
        codes_sum = torch.zeros_like(z)
        ids = torch.full((*z.shape[:-1], self.num_layers), -1, dtype=torch.long, device=z.device)
        perplexity = torch.zeros(self.num_layers, device=z.device)
        usage = torch.zeros(self.num_layers, device=z.device)
        commit = []
        for k, layer in enumerate(self.layers[:active]):
            out = layer(residual, gen)
            residual = residual - out.codes  # r_{k+1} = r_k − sg(q_k): codes carry no gradient
            codes_sum = codes_sum + out.codes
            ids[..., k] = out.ids
            perplexity[k], usage[k] = out.perplexity, out.usage
            commit.append(out.commit_loss)
        # One straight-through for the sum: the decoder's gradient reaches z once (MoMask adds one
        # straight-through per layer, which multiplies the encoder's gradient by the number of layers).
        quantized = z + (codes_sum - z).detach()
        return QuantizeOutput(quantized, codes_sum, ids, torch.stack(commit).mean(), perplexity, usage)

    @torch.no_grad()
    def quantize(self, z: torch.Tensor, num_layers: int | None = None) -> torch.Tensor:
        """Deterministic residual argmin: ``(..., C)`` → ids ``(..., R)`` (layers past ``num_layers`` are −1), on the
        codebooks' device."""
        n = self.num_layers if num_layers is None else num_layers
        z = z.to(self.layers[0].codebook.device)
        ids = torch.full((*z.shape[:-1], self.num_layers), -1, dtype=torch.long, device=z.device)
        residual = z
        for k, layer in enumerate(self.layers[:n]):
            ids[..., k] = layer.quantize(residual)
            residual = residual - layer.lookup(ids[..., k])
        return ids

    def get_codes_from_indices(self, ids: torch.Tensor) -> torch.Tensor:
        """Per-layer code vectors: ids ``(..., R')`` with R' ≤ R → ``(R', ..., C)``; index −1 gives a zero vector.
        On the codebooks' device."""
        ids = ids.to(self.layers[0].codebook.device)
        out = []
        for k in range(ids.shape[-1]):
            idx = ids[..., k]
            vec = self.layers[k].lookup(idx.clamp_min(0))
            out.append(vec * (idx >= 0).unsqueeze(-1).to(vec.dtype))
        return torch.stack(out)

    def codes_to_latent(self, ids: torch.Tensor, num_layers: int | None = None) -> torch.Tensor:
        """Σ_k q_k over the first ``num_layers`` layers of ``ids (..., R')`` → ``(..., C)``."""
        n = ids.shape[-1] if num_layers is None else num_layers
        return self.get_codes_from_indices(ids[..., :n]).sum(0)
