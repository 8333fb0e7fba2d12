"""The 1D convolutional encoder and decoder of T2M-GPT / MoMask motion tokenizers.

Time is the convolution axis and features are channels. Two stride-2 convolutions (kernel 4, padding 1)
shrink T frames to T/4 latent vectors; the decoder mirrors them with nearest-neighbour ×2 upsampling.
Between resolutions sit stacks of dilated residual blocks whose receptive field grows as 3^k.

    Encoder: (B, T, D) → conv3 → ReLU → 2 × [conv4/s2 → Resnet1D] → conv3 → (B, T/4, C)
    Decoder: (B, T/4, C) → conv3 → ReLU → 2 × [Resnet1D → up×2 → conv3] → conv3 → ReLU → conv3 → (B, T, D)
"""

from __future__ import annotations

import torch
from torch import nn

DOWN_STAGES = 2  # two stride-2 stages: temporal downsampling by 4


class ResConv1DBlock(nn.Module):
    """Pre-activation residual block: x + conv1(ReLU(conv3_dilated(ReLU(x)))).

    Padding = dilation keeps the length; the 1×1 conv mixes channels after the wide temporal one.
    """

    def __init__(self, width: int, dilation: int, dropout: float = 0.0):
        super().__init__()
        self.conv1 = nn.Conv1d(width, width, kernel_size=3, padding=dilation, dilation=dilation)
        self.conv2 = nn.Conv1d(width, width, kernel_size=1)
        self.act = nn.ReLU()
        self.dropout = nn.Dropout(dropout)  # MoMask uses 0.2, T2M-GPT none

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # (B, W, T) -> (B, W, T)
        h = self.conv2(self.act(self.conv1(self.act(x))))
        return x + self.dropout(h)


class Resnet1D(nn.Sequential):
    """``depth`` residual blocks with dilations growth^k, applied largest first (e.g. 9, 3, 1)."""

    def __init__(self, width: int, depth: int, dilation_growth: int = 3, dropout: float = 0.0):
        dilations = [dilation_growth**k for k in range(depth)][::-1]
        super().__init__(*(ResConv1DBlock(width, d, dropout) for d in dilations))


class Encoder(nn.Module):
    """Motion features ``(B, T, D)`` → latent vectors ``(B, T/4, code_dim)``."""

    def __init__(
        self, feature_dim: int, code_dim: int, width: int, depth: int, dilation_growth: int = 3, dropout: float = 0.0
    ):
        super().__init__()
        layers: list[nn.Module] = [nn.Conv1d(feature_dim, width, 3, padding=1), nn.ReLU()]
        for _ in range(DOWN_STAGES):
            layers += [
                nn.Conv1d(width, width, 4, stride=2, padding=1),  # T -> T/2
                Resnet1D(width, depth, dilation_growth, dropout),
            ]
        layers.append(nn.Conv1d(width, code_dim, 3, padding=1))
        self.net = nn.Sequential(*layers)

    def forward(self, motion: torch.Tensor) -> torch.Tensor:
        return self.net(motion.transpose(1, 2)).transpose(1, 2)  # (B, T, D) -> (B, D, T) -> (B, T/4, C)


class Decoder(nn.Module):
    """Latent vectors ``(B, N, code_dim)`` → motion features ``(B, 4N, D)``."""

    def __init__(
        self, feature_dim: int, code_dim: int, width: int, depth: int, dilation_growth: int = 3, dropout: float = 0.0
    ):
        super().__init__()
        layers: list[nn.Module] = [nn.Conv1d(code_dim, width, 3, padding=1), nn.ReLU()]
        for _ in range(DOWN_STAGES):
            layers += [
                Resnet1D(width, depth, dilation_growth, dropout),
                nn.Upsample(scale_factor=2, mode="nearest"),
                nn.Conv1d(width, width, 3, padding=1),
            ]
        layers += [nn.Conv1d(width, width, 3, padding=1), nn.ReLU(), nn.Conv1d(width, feature_dim, 3, padding=1)]
        self.net = nn.Sequential(*layers)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        return self.net(z.transpose(1, 2)).transpose(1, 2)  # (B, N, C) -> (B, C, N) -> (B, 4N, D)
