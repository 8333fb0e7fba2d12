"""Tiny random denoisers for the multi-motion tests (K = 12 codes, T = 10 steps, 8-d text)."""

from __future__ import annotations

import pytest
import torch

from motionlab.diffusion import DenoisingTransformer, build_transitions, get_schedule, transformer_config

K, D_TEXT, T = 12, 8, 10  # the test files use the same numbers


@pytest.fixture(scope="session")
def tiny():
    """A random smoke-size denoiser with larger weights (std 0.3), so that its predictions — and hence the
    sampled tokens — react visibly to their context, and the dynamic transitions of a random codebook."""
    cfg = transformer_config("smoke", num_codes=K, text_dim=D_TEXT, timesteps=T)
    model = DenoisingTransformer(cfg, seed=0).eval()
    g = torch.Generator().manual_seed(5)
    with torch.no_grad():
        for p in model.parameters():
            if p.ndim >= 2:
                p.normal_(0.0, 0.3, generator=g)
    codebook = torch.randn(K, 3, generator=torch.Generator().manual_seed(1))
    transitions = build_transitions(get_schedule(T=T), codebook=codebook, eta=0.5)
    return model, transitions
