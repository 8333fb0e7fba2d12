"""The denoising transformer p_θ(x_0 | x_t, y) of M2D2M §4.4 (after VQ-Diffusion's Text2ImageTransformer).

::

    x_t (B, L) ids in [0, K]  ──Embedding(K+1, d)──►  h (B, L, d)
    t   (B,)                  ──sinusoid → MLP──────►  e (B, d)            (time, for every AdaLN)
    for each of n_layers blocks (pre-norm):
        h += SelfAttn(AdaLN(h, e))          bias: T5 relative positions (+ padding / optional mask)
        h += CrossAttn(AdaLN(h, e), text)   keys: text token features (+ padding / optional (B, L, S) mask)
        h += MLP(AdaLN(h, e))
    log p(x_0 | x_t) = log_softmax(Linear(LN(h)))        (B, L, K)

- **AdaLN**: LayerNorm without affine, then ·(1 + scale) + shift with (scale, shift) = Linear(SiLU(e)); the
  Linear starts at zero, so an untrained block sees a plain LayerNorm.
- **Relative positions** (M2D2M cites T5 [46] for them): a learned bias per head for each bucket of the
  signed offset j − i; offsets up to 8 get their own bucket, longer ones share logarithmic buckets up to
  ``rel_max_distance`` and everything further shares the last bucket. No position is ever unseen, so
  sequences longer than any in training (several segments concatenated, Two-Phase Sampling) just work.
- **Cross-attention** to the text's token features (CLIP's 77 tokens in the paper) with a key padding mask.
  The optional ``cross_mask`` (B, L, S) says which text tokens each motion token may see: with several
  segments' texts concatenated along S, a per-token segment id selects its own text
  (:func:`segment_cross_mask`). ``self_mask`` (B, L, L) likewise can keep segments apart in self-attention.
- **Classifier-free guidance**: a learned null text token ∅ replaces the text of a sample with probability
  ``cond_drop_prob`` (10 % in training) or where ``drop_text`` says so (the unconditional branch at sampling).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from motionlab.checks import values_checked
from motionlab.precision import attention_kernel
from motionlab.sizes import DENOISER, resized


@dataclass(frozen=True)
class TransformerConfig:
    # --- network
    num_codes: int = 512  # K (mask id = K)
    text_dim: int = 512  # width of the text encoder's token features (CLIP ViT-B/32: 512)
    n_layers: int = 12
    n_heads: int = 16
    d_model: int = 512
    d_ff: int = 2048
    dropout: float = 0.0
    timesteps: int = 100  # T
    rel_buckets: int = 32  # T5 relative-position buckets (both directions together)
    rel_max_distance: int = 128  # offsets beyond this share the last bucket
    # --- diffusion (M2D2M appendix A.1)
    schedule: str = "vqdiffusion_paper"  # see motionlab.diffusion.schedule
    eta: float = 0.5  # dynamic transition scale (0.25 for multi-motion)
    distance: str = "l2_rank"
    aux_weight: float = 5e-4  # λ
    cond_drop_prob: float = 0.1  # text replaced by ∅ in training
    guidance_scale: float = 4.0  # s of Eq. 9 for single motions (2.0 for multi-motion)
    # --- training
    lr: float = 2e-4
    lr_decayed: float = 2e-5  # after decay_epoch
    betas: tuple[float, float] = (0.9, 0.99)
    weight_decay: float = 4.5e-2
    epochs: int = 110
    decay_epoch: int = 100
    batch_size: int = 64
    train_steps: int | None = None  # profiles that count steps instead of epochs

    def __post_init__(self) -> None:
        if self.d_model % self.n_heads:
            raise ValueError(f"d_model={self.d_model} must be divisible by n_heads={self.n_heads}")
        if self.num_codes < 2 or self.timesteps < 1 or self.rel_buckets < 4:
            raise ValueError("need num_codes >= 2, timesteps >= 1, rel_buckets >= 4")
        if not 0.0 <= self.cond_drop_prob < 1.0:
            raise ValueError(f"cond_drop_prob must be in [0, 1), got {self.cond_drop_prob}")


def transformer_config(profile: str | None = None, **overrides) -> TransformerConfig:
    """The denoiser config of a run profile (smoke: tiny; laptop: small; full: M2D2M's), with overrides."""
    return replace(resized(TransformerConfig(), DENOISER, profile), **overrides)


# ---------------------------------------------------------------------------------------------- pieces


def relative_position_bucket(offset: Tensor, num_buckets: int, max_distance: int) -> Tensor:
    """T5's bidirectional bucket of a signed offset j − i (key minus query): int tensor, same shape.

    Half the buckets are for j > i. Within a half, |offset| < n/4 has an exact bucket; larger offsets are
    spaced logarithmically up to ``max_distance``; beyond it they share the half's last bucket.
    """
    half = num_buckets // 2
    bucket = (offset > 0).long() * half
    n = offset.abs()
    exact = half // 2
    far = exact + (torch.log(n.clamp_min(1).float() / exact) / math.log(max_distance / exact) * (half - exact)).long()
    far = far.clamp(max=half - 1)
    return bucket + torch.where(n < exact, n, far)


def timestep_embedding(t: Tensor, dim: int, T: int) -> Tensor:
    """(B,) steps -> (B, dim) sinusoids of t·(1000/T) (so the frequencies fit any T)."""
    half = dim // 2
    freqs = torch.exp(-math.log(10_000.0) * torch.arange(half, device=t.device, dtype=torch.float32) / half)
    angles = (t.float() * (1000.0 / T))[:, None] * freqs[None]  # (B, half)
    emb = torch.cat([angles.sin(), angles.cos()], dim=-1)
    return F.pad(emb, (0, dim % 2))


class AdaLayerNorm(nn.Module):
    """LN(x) · (1 + scale(e)) + shift(e): the diffusion step enters every block through its norms."""

    def __init__(self, d_model: int) -> None:
        super().__init__()
        self.norm = nn.LayerNorm(d_model, elementwise_affine=False)
        self.modulation = nn.Linear(d_model, 2 * d_model)

    def forward(self, x: Tensor, emb: Tensor) -> Tensor:  # x (B, L, d), emb (B, d)
        scale, shift = self.modulation(F.silu(emb)).unsqueeze(1).chunk(2, dim=-1)  # (B, 1, d) each
        return self.norm(x) * (1.0 + scale) + shift


class Attention(nn.Module):
    """Multi-head attention with an additive (B, H | 1, L, S) bias; self- or cross- by the key source."""

    def __init__(self, d_model: int, n_heads: int, kv_dim: int | None = None, dropout: float = 0.0) -> None:
        super().__init__()
        kv_dim = kv_dim or d_model
        self.n_heads, self.dropout = n_heads, dropout
        self.q = nn.Linear(d_model, d_model)
        self.kv = nn.Linear(kv_dim, 2 * d_model)
        self.out = nn.Linear(d_model, d_model)

    def forward(self, x: Tensor, source: Tensor, bias: Tensor) -> Tensor:
        B, L, d = x.shape
        H = self.n_heads
        q = self.q(x).view(B, L, H, d // H).transpose(1, 2)  # (B, H, L, dh)
        k, v = self.kv(source).view(B, source.shape[1], 2, H, d // H).permute(2, 0, 3, 1, 4)  # (B, H, S, dh)
        with attention_kernel(x.device):
            y = F.scaled_dot_product_attention(
                q, k, v, attn_mask=bias, dropout_p=self.dropout if self.training else 0.0
            )
        return self.out(y.transpose(1, 2).reshape(B, L, d))


class Block(nn.Module):
    def __init__(self, cfg: TransformerConfig) -> None:
        super().__init__()
        d = cfg.d_model
        self.norm_self, self.norm_cross, self.norm_mlp = AdaLayerNorm(d), AdaLayerNorm(d), AdaLayerNorm(d)
        self.self_attn = Attention(d, cfg.n_heads, dropout=cfg.dropout)
        self.cross_attn = Attention(d, cfg.n_heads, kv_dim=d, dropout=cfg.dropout)
        self.mlp = nn.Sequential(nn.Linear(d, cfg.d_ff), nn.GELU(), nn.Linear(cfg.d_ff, d), nn.Dropout(cfg.dropout))

    def forward(self, h: Tensor, emb: Tensor, text: Tensor, self_bias: Tensor, cross_bias: Tensor) -> Tensor:
        normed = self.norm_self(h, emb)
        h = h + self.self_attn(normed, normed, self_bias)
        h = h + self.cross_attn(self.norm_cross(h, emb), text, cross_bias)
        return h + self.mlp(self.norm_mlp(h, emb))


def _mask_to_bias(allowed: Tensor) -> Tensor:
    """Bool (B, L, S) 'may attend' -> additive (B, 1, L, S) bias; a row with nothing allowed sees everything
    (its output belongs to a padded token and is never used, but −inf everywhere would give NaN)."""
    allowed = allowed | ~allowed.any(dim=-1, keepdim=True)
    return torch.zeros(allowed.shape, device=allowed.device).masked_fill(~allowed, float("-inf")).unsqueeze(1)


def segment_cross_mask(token_segments: Tensor, text_segments: Tensor) -> Tensor:
    """(B, L) segment id per motion token and (B, S) segment id per text token -> (B, L, S) bool
    'token may attend to text token' (same segment). For Two-Phase Sampling's joint phase."""
    return token_segments[:, :, None] == text_segments[:, None, :]


# ---------------------------------------------------------------------------------------------- model


class DenoisingTransformer(nn.Module):
    """log p_θ(x_0 | x_t, text): (B, L) ids in [0, K] and (B,) steps -> (B, L, K) log-probabilities."""

    def __init__(self, cfg: TransformerConfig, seed: int = 0) -> None:
        super().__init__()
        self.cfg = cfg
        d = cfg.d_model
        self.token_emb = nn.Embedding(cfg.num_codes + 1, d)
        self.time_mlp = nn.Sequential(nn.Linear(d, d), nn.SiLU(), nn.Linear(d, d))
        self.text_proj = nn.Sequential(nn.LayerNorm(cfg.text_dim), nn.Linear(cfg.text_dim, d))
        self.null_text = nn.Parameter(torch.zeros(1, 1, cfg.text_dim))  # ∅ of classifier-free guidance
        self.rel_bias = nn.Embedding(cfg.rel_buckets, cfg.n_heads)  # shared by all layers (as in T5)
        self.blocks = nn.ModuleList(Block(cfg) for _ in range(cfg.n_layers))
        self.norm_out = nn.LayerNorm(d)
        self.head = nn.Linear(d, cfg.num_codes)
        self.reset_parameters(torch.Generator().manual_seed(seed))

    @torch.no_grad()
    def reset_parameters(self, generator: torch.Generator) -> None:
        """normal(0, 0.02) weights, zero biases, unit LayerNorms, zero AdaLN modulation (seeded)."""
        for module in self.modules():
            if isinstance(module, (nn.Linear, nn.Embedding)):
                nn.init.normal_(module.weight, 0.0, 0.02, generator=generator)
                if getattr(module, "bias", None) is not None:
                    nn.init.zeros_(module.bias)
            elif isinstance(module, nn.LayerNorm) and module.elementwise_affine:
                nn.init.ones_(module.weight)
                nn.init.zeros_(module.bias)
        for module in self.modules():
            if isinstance(module, AdaLayerNorm):
                nn.init.zeros_(module.modulation.weight)
                nn.init.zeros_(module.modulation.bias)
        nn.init.normal_(self.null_text, 0.0, 1.0, generator=generator)

    @property
    def num_params(self) -> int:
        return sum(p.numel() for p in self.parameters())

    def forward(
        self,
        x_t: Tensor,
        t: Tensor,
        text: Tensor,
        text_padding_mask: Tensor | None = None,
        *,
        padding_mask: Tensor | None = None,
        cross_mask: Tensor | None = None,
        self_mask: Tensor | None = None,
        drop_text: Tensor | None = None,
        cond_drop_prob: float = 0.0,
        generator: torch.Generator | None = None,
    ) -> Tensor:
        """Args:
            x_t: (B, L) long ids in [0, K] (K = mask).
            t: (B,) long steps in [0, T] (or an int for the whole batch).
            text: (B, S, text_dim) text token features; ``text_padding_mask`` (B, S) True at padding.
            padding_mask: (B, L) True at padded motion tokens (never attended to).
            cross_mask: optional (B, L, S) bool, True where a motion token may attend to a text token.
            self_mask: optional (B, L, L) bool, True where a motion token may attend to another.
            drop_text: optional (B,) bool: replace that sample's text by the null condition ∅.
            cond_drop_prob: additionally drop each sample's text with this probability (needs ``generator``).
        Returns:
            (B, L, K) log p_θ(x_0 | x_t).
        """
        B, L, S = self._check(x_t, t, text, text_padding_mask, padding_mask, cross_mask, self_mask, drop_text)
        dev = x_t.device
        t = torch.as_tensor(t, device=dev).long().expand(B) if not torch.is_tensor(t) or t.ndim == 0 else t.to(dev)
        drop = torch.zeros(B, dtype=torch.bool, device=dev) if drop_text is None else drop_text.to(dev).bool()
        if cond_drop_prob > 0:
            if not isinstance(generator, torch.Generator):
                raise ValueError("cond_drop_prob > 0 needs a seeded torch.Generator")
            drop = drop | (torch.rand(B, generator=generator, device=generator.device) < cond_drop_prob).to(dev)

        # Text keys: the S real tokens, then ∅. A kept text hides ∅; a dropped text shows only ∅.
        keys = torch.cat([text, self.null_text.expand(B, 1, -1).to(text.dtype)], dim=1)  # (B, S+1, text_dim)
        keys = self.text_proj(keys)  # (B, S+1, d)
        allowed = torch.ones(B, L, S, dtype=torch.bool, device=dev) if cross_mask is None else cross_mask.bool()
        if text_padding_mask is not None:
            allowed = allowed & ~text_padding_mask.bool()[:, None, :]
        allowed = allowed & ~drop[:, None, None]
        allowed = torch.cat([allowed, drop[:, None, None].expand(B, L, 1)], dim=-1)  # (B, L, S+1)
        cross_bias = _mask_to_bias(allowed)  # (B, 1, L, S+1)

        pos = torch.arange(L, device=dev)
        buckets = relative_position_bucket(pos[None, :] - pos[:, None], self.cfg.rel_buckets, self.cfg.rel_max_distance)
        self_bias = self.rel_bias(buckets).permute(2, 0, 1).unsqueeze(0)  # (1, H, L, L)
        keep = torch.ones(B, L, L, dtype=torch.bool, device=dev) if self_mask is None else self_mask.bool()
        if padding_mask is not None:
            keep = keep & ~padding_mask.bool()[:, None, :]
        self_bias = self_bias + _mask_to_bias(keep)  # (B, H, L, L)

        emb = self.time_mlp(timestep_embedding(t, self.cfg.d_model, self.cfg.timesteps))  # (B, d)
        h = self.token_emb(x_t)  # (B, L, d)
        for block in self.blocks:
            h = block(h, emb, keys, self_bias, cross_bias)
        return F.log_softmax(self.head(self.norm_out(h)).float(), dim=-1)  # (B, L, K)

    def _check(self, x_t, t, text, text_padding_mask, padding_mask, cross_mask, self_mask, drop_text):
        K = self.cfg.num_codes
        if not torch.is_tensor(x_t) or x_t.ndim != 2 or x_t.dtype != torch.long:
            raise ValueError(f"x_t must be a (B, L) long tensor, got {getattr(x_t, 'shape', type(x_t))}")
        B, L = x_t.shape
        if x_t.numel() and values_checked(x_t) and (x_t.min() < 0 or x_t.max() > K):
            raise ValueError(f"x_t ids must be in [0, {K}] (K = mask), got [{x_t.min()}, {x_t.max()}]")
        if torch.is_tensor(t) and t.ndim > 0 and t.shape != (B,):
            raise ValueError(f"t must be (B,) = ({B},) or a scalar, got {tuple(t.shape)}")
        t_val = torch.as_tensor(t)
        if t_val.numel() and values_checked(t_val) and (t_val.min() < 0 or t_val.max() > self.cfg.timesteps):
            raise ValueError(f"t must be in [0, {self.cfg.timesteps}]")
        if not torch.is_tensor(text) or text.ndim != 3 or text.shape[0] != B or text.shape[2] != self.cfg.text_dim:
            raise ValueError(f"text must be (B={B}, S, {self.cfg.text_dim}), got {getattr(text, 'shape', None)}")
        S = text.shape[1]
        for name, m, shape in (
            ("text_padding_mask", text_padding_mask, (B, S)),
            ("padding_mask", padding_mask, (B, L)),
            ("cross_mask", cross_mask, (B, L, S)),
            ("self_mask", self_mask, (B, L, L)),
            ("drop_text", drop_text, (B,)),
        ):
            if m is not None and tuple(m.shape) != shape:
                raise ValueError(f"{name} must be {shape}, got {tuple(m.shape)}")
        return B, L, S
