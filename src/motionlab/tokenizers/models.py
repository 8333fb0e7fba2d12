"""The two motion tokenizers: ``VQVAE`` (one codebook) and ``RVQVAE`` (residual codebooks).

Both are encoder → quantiser → decoder and implement :class:`~motionlab.tokenizers.base.Tokenizer`.
``forward`` is the training path (codebook updates, quantize dropout); ``encode``/``embed``/``decode``
are the pure inference path (argmin, no state change) that the rest of the book uses.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from ..train import seeded
from .base import check_ids, check_motion
from .config import RVQConfig, VQConfig
from .encdec import Decoder, Encoder
from .quantizer import QuantizerEMAReset
from .residual_vq import ResidualVQ


@dataclass
class TokenizerOutput:
    recon: torch.Tensor  # (B, T, D) reconstructed motion
    ids: torch.Tensor  # (B, T/4) or (B, T/4, R)
    commit_loss: torch.Tensor  # scalar
    perplexity: torch.Tensor  # scalar (VQ) or per layer (R,) (RVQ)
    usage: torch.Tensor  # fraction of codes used in the batch, scalar or (R,)


class ConvTokenizer(nn.Module):
    """What VQ and RVQ share: the conv encoder/decoder, input checks and the inference API."""

    downsample = 4

    def __init__(self, config: VQConfig):
        super().__init__()
        self.config = config
        self.feature_dim, self.code_dim, self.codebook_size = config.feature_dim, config.code_dim, config.codebook_size
        c = config
        self.encoder = Encoder(c.feature_dim, c.code_dim, c.width, c.depth, c.dilation_growth, c.dropout)
        self.decoder = Decoder(c.feature_dim, c.code_dim, c.width, c.depth, c.dilation_growth, c.dropout)

    def _check_motion(self, motion) -> torch.Tensor:
        return check_motion(motion, self.feature_dim, self.downsample).to(self.device)

    @property
    def device(self) -> torch.device:
        return next(self.parameters()).device

    def decode_latent(self, z: torch.Tensor) -> torch.Tensor:
        """Continuous latents ``(B, N, code_dim)`` → motion ``(B, 4N, D)``, on the tokenizer's device."""
        return self.decoder(z.to(self.device))

    def decode(self, ids: torch.Tensor, **kwargs) -> torch.Tensor:
        """Ids → normalised motion ``(B, T, D)``."""
        return self.decode_latent(self.embed(ids, **kwargs))


class VQVAE(ConvTokenizer):
    """T2M-GPT's VQ-VAE: one EMA codebook with dead-code reset."""

    num_layers = 1

    def __init__(self, config: VQConfig):
        with seeded(config.seed):  # weights are a function of the config alone
            super().__init__(config)
            c = config
            self.quantizer = QuantizerEMAReset(
                c.codebook_size, c.code_dim, c.ema_decay, c.reset_threshold, c.gumbel_temperature, seed=c.seed
            )

    def forward(self, motion: torch.Tensor, generator: torch.Generator | None = None) -> TokenizerOutput:
        motion = self._check_motion(motion)
        z = self.encoder(motion)  # (B, T/4, C)
        q = self.quantizer(z, generator)
        recon = self.decoder(q.quantized)  # (B, T, D)
        return TokenizerOutput(recon, q.ids, q.commit_loss, q.perplexity, q.usage)

    @torch.no_grad()
    def encode(self, motion: torch.Tensor) -> torch.Tensor:
        """Motion ``(B, T, D)`` → ids ``(B, T/4)`` by nearest code."""
        return self.quantizer.quantize(self.encoder(self._check_motion(motion)))

    def embed(self, ids: torch.Tensor) -> torch.Tensor:
        """Ids ``(B, N)`` → code vectors ``(B, N, code_dim)``."""
        return self.quantizer.lookup(check_ids(ids, self.codebook_size).to(self.device))

    def codebook(self, layer: int = 0) -> torch.Tensor:
        if layer != 0:
            raise ValueError(f"a VQVAE has a single codebook (layer 0), got layer={layer}")
        return self.quantizer.codebook.detach()


class RVQVAE(ConvTokenizer):
    """MoMask's residual VQ-VAE: ``num_layers`` codebooks on successive residuals, with quantize dropout."""

    def __init__(self, config: RVQConfig):
        with seeded(config.seed):
            super().__init__(config)
            self.num_layers = config.num_layers
            c = config
            self.quantizer = ResidualVQ(
                c.num_layers,
                c.codebook_size,
                c.code_dim,
                c.quantize_dropout,
                c.ema_decay,
                c.reset_threshold,
                c.gumbel_temperature,
                seed=c.seed,
            )

    def _check_layers(self, num_layers: int | None, available: int) -> int:
        n = available if num_layers is None else num_layers
        if not 1 <= n <= available:
            raise ValueError(f"num_layers must be in [1, {available}], got {num_layers}")
        return n

    def forward(self, motion: torch.Tensor, generator: torch.Generator | None = None) -> TokenizerOutput:
        motion = self._check_motion(motion)
        z = self.encoder(motion)  # (B, T/4, C)
        q = self.quantizer(z, generator)
        recon = self.decoder(q.quantized)  # (B, T, D)
        return TokenizerOutput(recon, q.ids, q.commit_loss, q.perplexity, q.usage)

    @torch.no_grad()
    def encode(self, motion: torch.Tensor, num_layers: int | None = None) -> torch.Tensor:
        """Motion ``(B, T, D)`` → ids ``(B, T/4, R)``; layers past ``num_layers`` are −1."""
        n = self._check_layers(num_layers, self.num_layers)
        return self.quantizer.quantize(self.encoder(self._check_motion(motion)), n)

    def embed(self, ids: torch.Tensor, num_layers: int | None = None) -> torch.Tensor:
        """Ids ``(B, N, R')`` → Σ of the first ``num_layers`` layers' code vectors ``(B, N, code_dim)``."""
        ids = check_ids(ids, self.codebook_size, self.num_layers).to(self.device)
        return self.quantizer.codes_to_latent(ids, self._check_layers(num_layers, ids.shape[-1]))

    def get_codes_from_indices(self, ids: torch.Tensor) -> torch.Tensor:
        """Per-layer code vectors ``(R', B, N, code_dim)``; −1 gives zeros (DisCoRD sums them over layers)."""
        ids = check_ids(ids, self.codebook_size, self.num_layers).to(self.device)
        return self.quantizer.get_codes_from_indices(ids)

    def codebook(self, layer: int = 0) -> torch.Tensor:
        if not 0 <= layer < self.num_layers:
            raise ValueError(f"layer must be in [0, {self.num_layers}), got {layer}")
        return self.quantizer.layers[layer].codebook.detach()


def build_tokenizer(config: VQConfig) -> VQVAE | RVQVAE:
    """The model a config describes: :class:`RVQVAE` for an :class:`RVQConfig`, else :class:`VQVAE`."""
    if isinstance(config, RVQConfig):
        return RVQVAE(config)
    if isinstance(config, VQConfig):
        return VQVAE(config)
    raise ValueError(f"config must be a VQConfig or RVQConfig, got {type(config).__name__}")
