"""The DisCoRD vector field: a 1D U-Net over time, without attention.

    x_t (B, T, D) ‖ c (B, T, c_dim)  --cat on channels, 1×1 conv-->  h (B, w, T)      (r = h kept for the end)
    t ∈ [0, 1] --sinusoidal(w)--> MLP --> temb (B, 4w)                                  (t is used as is, no ×1000)
    down:  level i: ResNet(d_i → d_i) ×k, keep skip, then Downsample(d_i → d_{i+1}) (a k3 conv at the last level)
    mid:   ResNet(d_L), ResNet(d_L)
    up:    level i: cat skip, ResNet(d_{i+1} + d_i → d_{i+1}) ×k, then Upsample(d_{i+1} → d_i) (k3 conv at the last)
    out:   cat r, ResNet(2w → w), 1×1 conv → v (B, T, D)

Channel widths ``dims = [w] + [w·m for m in width_mults]``; DisCoRD uses w = 512, mults (1, 2), i.e.
dims [512, 512, 1024] with one stride-2 downsampling. Every layer is a convolution, so a network trained
on 64-frame windows runs on any length that is a multiple of :attr:`UNetConfig.length_multiple`.

ResNet block (time-modulated): ``Conv3 → RMSNorm → h·(1 + scale) + shift → SiLU → Dropout``, then
``Conv3 → RMSNorm → SiLU → Dropout``, plus a residual (1×1 conv when widths differ), where
``(scale, shift) = Linear(SiLU(temb))``. RMSNorm over channels: ``g · √C · h / ‖h‖₂``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn


@dataclass(frozen=True)
class UNetConfig:
    feature_dim: int = 263  # D: motion features per frame (263 HumanML3D, 251 KIT)
    cond_dim: int = 256  # c: frame-wise condition width
    width: int = 512  # w: channels after the 1×1 input projection
    width_mults: tuple[int, ...] = (1, 2)  # dims = [w, w·m_0, w·m_1, ...]
    resnets_per_level: int = 1  # ResNet blocks per down/up level (each holds two conv blocks)
    dropout: float = 0.0
    time_theta: float = 10000.0  # sinusoidal embedding base
    length_multiple: int = 4  # T must be a multiple of this (token stride q; ≥ 2^downsamplings)

    def __post_init__(self) -> None:
        for name in ("feature_dim", "cond_dim", "width", "resnets_per_level", "length_multiple"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"UNetConfig.{name} must be a positive int, got {value!r}")
        if len(self.width_mults) < 1 or any(int(m) < 1 for m in self.width_mults):
            raise ValueError(f"UNetConfig.width_mults must be positive ints, got {self.width_mults!r}")
        if self.width % 2:
            raise ValueError(f"UNetConfig.width must be even (sinusoidal embedding), got {self.width}")
        if self.length_multiple % (2**self.n_downsamplings):
            raise ValueError(
                f"UNetConfig.length_multiple={self.length_multiple} must be a multiple of "
                f"2^{self.n_downsamplings} (one halving per level but the last)"
            )

    @property
    def dims(self) -> list[int]:
        return [self.width] + [self.width * int(m) for m in self.width_mults]

    @property
    def n_downsamplings(self) -> int:
        return len(self.width_mults) - 1

    @property
    def time_dim(self) -> int:
        return 4 * self.width


# ----------------------------------------------------------------------------- building blocks


class SinusoidalTimeEmbedding(nn.Module):
    """``[sin(t·ω_k), cos(t·ω_k)]`` with ``ω_k = θ^(−k/(h−1))``, ``k = 0..h−1``, ``h = dim/2``."""

    def __init__(self, dim: int, theta: float = 10000.0) -> None:
        super().__init__()
        half = dim // 2
        freqs = torch.exp(-math.log(theta) * torch.arange(half) / max(half - 1, 1))
        self.register_buffer("freqs", freqs, persistent=False)

    def forward(self, t: Tensor) -> Tensor:
        angles = t[:, None].float() * self.freqs[None]  # (B, dim/2)
        return torch.cat([angles.sin(), angles.cos()], dim=-1)  # (B, dim)


class RMSNorm(nn.Module):
    """Normalise each frame's channel vector to norm √C, then a learned per-channel gain."""

    def __init__(self, channels: int) -> None:
        super().__init__()
        self.gain = nn.Parameter(torch.ones(1, channels, 1))
        self.scale = math.sqrt(channels)

    def forward(self, x: Tensor) -> Tensor:  # (B, C, T)
        return F.normalize(x, dim=1) * self.gain * self.scale


class ConvBlock(nn.Module):
    """``Conv3 → RMSNorm → optional h·(1 + scale) + shift → SiLU → Dropout``."""

    def __init__(self, din: int, dout: int, dropout: float) -> None:
        super().__init__()
        self.conv = nn.Conv1d(din, dout, kernel_size=3, padding=1)
        self.norm = RMSNorm(dout)
        self.drop = nn.Dropout(dropout)

    def forward(self, x: Tensor, scale_shift: tuple[Tensor, Tensor] | None = None) -> Tensor:
        h = self.norm(self.conv(x))
        if scale_shift is not None:
            scale, shift = scale_shift  # (B, dout, 1) each
            h = h * (1 + scale) + shift
        return self.drop(F.silu(h))


class ResnetBlock(nn.Module):
    """Two conv blocks, the first modulated by the time embedding, plus a residual connection."""

    def __init__(self, din: int, dout: int, time_dim: int, dropout: float) -> None:
        super().__init__()
        self.to_scale_shift = nn.Sequential(nn.SiLU(), nn.Linear(time_dim, 2 * dout))
        self.block1 = ConvBlock(din, dout, dropout)
        self.block2 = ConvBlock(dout, dout, dropout)
        self.residual = nn.Conv1d(din, dout, kernel_size=1) if din != dout else nn.Identity()

    def forward(self, x: Tensor, temb: Tensor) -> Tensor:
        scale, shift = self.to_scale_shift(temb)[:, :, None].chunk(2, dim=1)  # (B, dout, 1) each
        h = self.block2(self.block1(x, (scale, shift)))
        return h + self.residual(x)


def downsample(din: int, dout: int) -> nn.Module:
    """Halve the length: ``Conv1d(k=4, stride=2, pad=1)``."""
    return nn.Conv1d(din, dout, kernel_size=4, stride=2, padding=1)


def upsample(din: int, dout: int) -> nn.Module:
    """Double the length: nearest ×2 then ``Conv1d(k=3)``."""
    return nn.Sequential(nn.Upsample(scale_factor=2, mode="nearest"), nn.Conv1d(din, dout, 3, padding=1))


class Level(nn.Module):
    """One U-Net level: ResNet blocks and the resampling conv that follows them."""

    def __init__(self, blocks: list[ResnetBlock], resample: nn.Module) -> None:
        super().__init__()
        self.blocks = nn.ModuleList(blocks)
        self.resample = resample


# ----------------------------------------------------------------------------- the network


class UNet1D(nn.Module):
    """Vector field ``v(x_t, t, c)``: ``(B, T, D), (B,), (B, T, c_dim) -> (B, T, D)``."""

    def __init__(self, config: UNetConfig) -> None:
        super().__init__()
        self.config = cfg = config
        dims, k, p, tdim = cfg.dims, cfg.resnets_per_level, cfg.dropout, cfg.time_dim
        pairs = list(zip(dims[:-1], dims[1:]))  # [(d_0, d_1), (d_1, d_2), ...]
        last = len(pairs) - 1

        self.init_proj = nn.Conv1d(cfg.feature_dim + cfg.cond_dim, cfg.width, kernel_size=1)
        self.time_mlp = nn.Sequential(
            SinusoidalTimeEmbedding(cfg.width, cfg.time_theta),
            nn.Linear(cfg.width, tdim),
            nn.GELU(),
            nn.Linear(tdim, tdim),
        )
        self.downs = nn.ModuleList(
            Level(
                [ResnetBlock(din, din, tdim, p) for _ in range(k)],
                downsample(din, dout) if i < last else nn.Conv1d(din, dout, 3, padding=1),
            )
            for i, (din, dout) in enumerate(pairs)
        )
        self.mid = nn.ModuleList([ResnetBlock(dims[-1], dims[-1], tdim, p) for _ in range(2)])
        self.ups = nn.ModuleList(
            Level(
                [ResnetBlock(dout + din, dout, tdim, p) for _ in range(k)],
                upsample(dout, din) if i < last else nn.Conv1d(dout, din, 3, padding=1),
            )
            for i, (din, dout) in enumerate(reversed(pairs))
        )
        self.final_block = ResnetBlock(2 * cfg.width, cfg.width, tdim, p)
        self.final_conv = nn.Conv1d(cfg.width, cfg.feature_dim, kernel_size=1)

    def forward(self, x: Tensor, t: Tensor, cond: Tensor) -> Tensor:
        self._check(x, t, cond)
        # the condition enters once, at the input: concatenated to x_t frame by frame, then a 1×1 conv
        h = self.init_proj(torch.cat([x, cond], dim=-1).transpose(1, 2))  # (B, T, D + c) -> (B, w, T)
        r = h  # kept for the last block
        # t enters every ResNet block: its embedding sets a per-channel scale and shift (ResnetBlock.forward)
        temb = self.time_mlp(t)  # (B, 4w)

        skips = []
        for level in self.downs:
            for block in level.blocks:
                h = block(h, temb)
                skips.append(h)
            h = level.resample(h)  # (B, d_{i+1}, T / 2^(i+1)) except at the last level
        for block in self.mid:
            h = block(h, temb)
        for level in self.ups:
            for block in level.blocks:
                h = block(torch.cat([h, skips.pop()], dim=1), temb)
            h = level.resample(h)  # (B, d_i, ...) back up
        h = self.final_block(torch.cat([h, r], dim=1), temb)  # (B, w, T)
        return self.final_conv(h).transpose(1, 2)  # (B, T, D)

    def _check(self, x: Tensor, t: Tensor, cond: Tensor) -> None:
        cfg = self.config
        if not isinstance(x, Tensor) or x.dim() != 3 or x.shape[-1] != cfg.feature_dim:
            raise ValueError(f"x must have shape (B, T, {cfg.feature_dim}), got {_shape(x)}")
        B, T, _ = x.shape
        if T % cfg.length_multiple:
            raise ValueError(f"x length T={T} must be a multiple of {cfg.length_multiple}")
        if not isinstance(t, Tensor) or tuple(t.shape) != (B,):
            raise ValueError(f"t must have shape ({B},), got {_shape(t)}")
        if not isinstance(cond, Tensor) or tuple(cond.shape) != (B, T, cfg.cond_dim):
            raise ValueError(f"cond must have shape ({B}, {T}, {cfg.cond_dim}), got {_shape(cond)}")


def _shape(x: object) -> str:
    return str(tuple(x.shape)) if isinstance(x, Tensor) else type(x).__name__
