"""Tiny random denoisers for the multi-motion tests (K = 12 codes, T = 10 steps, 8-d text), and a stand-in
multi-motion generator."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from motionlab.diffusion import DenoisingTransformer, build_transitions, get_schedule, transformer_config
from motionlab.multimotion import MultiMotion

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


class NoisyConcat:
    """A stand-in generator: each instance's real clips back to back, plus noise seeded by ``seed`` (and, with
    ``by_method``, by the method, so that two methods differ)."""

    def __init__(self, instances, by_method: bool = False):
        self.by_texts = {tuple(inst.texts): inst for inst in instances}
        self.by_method = by_method

    def generate(self, texts, lengths, *, method, seed, **kw):
        rng = np.random.default_rng([seed, len(method)] if self.by_method else seed)
        out = []
        for t in texts:
            features, bounds = self.by_texts[tuple(t)].real_concat()
            noisy = features + rng.normal(0, 0.01, features.shape).astype(np.float32)
            out.append(MultiMotion(noisy, bounds, list(t), method))
        return out


@pytest.fixture(scope="session")
def noisy_concat():
    """``noisy_concat(instances, by_method=False)``: a :class:`NoisyConcat` generator for evaluate_methods."""
    return NoisyConcat
