"""The denoising transformer: shapes, masks, relative positions, null condition, configs, and a toy fit."""

from __future__ import annotations

import pytest
import torch

from motionlab.diffusion import (
    DenoisingTransformer,
    build_transitions,
    classifier_free_guidance,
    diffusion_loss,
    get_schedule,
    relative_position_bucket,
    segment_cross_mask,
    transformer_config,
    vb_terms,
)

K, D_TEXT, T = 8, 12, 10


def _model(seed: int = 0, **kw) -> DenoisingTransformer:
    cfg = transformer_config("smoke", num_codes=K, text_dim=D_TEXT, timesteps=T, **kw)
    return DenoisingTransformer(cfg, seed).eval()


def _inputs(B=2, L=7, S=4, seed=0):
    g = torch.Generator().manual_seed(seed)
    return (
        torch.randint(0, K + 1, (B, L), generator=g),
        torch.randint(0, T + 1, (B,), generator=g),
        torch.randn(B, S, D_TEXT, generator=g),
    )


def test_output_is_log_probabilities_over_codes():
    m = _model()
    x, t, text = _inputs()
    out = m(x, t, text)
    assert out.shape == (2, 7, K)
    torch.testing.assert_close(out.exp().sum(-1), torch.ones(2, 7))
    assert torch.equal(m(x, 3, text), m(x, torch.tensor([3, 3]), text))  # an int t covers the batch


def test_seeded_init_is_deterministic():
    x, t, text = _inputs()
    assert torch.equal(_model(1)(x, t, text), _model(1)(x, t, text))
    assert not torch.equal(_model(1)(x, t, text), _model(2)(x, t, text))


def test_relative_positions_run_beyond_training_lengths():
    buckets = relative_position_bucket(torch.arange(-500, 501), num_buckets=16, max_distance=32)
    assert buckets.min() >= 0 and buckets.max() < 16
    assert buckets[500] == 0 and (buckets[501:] >= 8).all() and (buckets[:500] < 8).all()  # sign halves
    assert buckets[0] == buckets[500 - 40] == 7 and buckets[-1] == 15  # far offsets share the last bucket
    m = _model()
    x, t, text = _inputs(L=300)
    out = m(x, t, text)  # smoke config: max distance 32, far shorter than 300
    assert out.shape == (2, 300, K) and torch.isfinite(out).all()


def test_padding_is_ignored():
    m = _model()
    x, t, text = _inputs(L=6)
    ref = m(x, t, text)
    x_long = torch.cat([x, torch.randint(0, K + 1, (2, 5))], dim=1)
    pad = torch.zeros(2, 11, dtype=torch.bool)
    pad[:, 6:] = True
    torch.testing.assert_close(m(x_long, t, text, padding_mask=pad)[:, :6], ref, atol=1e-5, rtol=0)
    text_long = torch.cat([text, torch.randn(2, 3, D_TEXT)], dim=1)
    tpad = torch.zeros(2, 7, dtype=torch.bool)
    tpad[:, 4:] = True
    torch.testing.assert_close(m(x, t, text_long, tpad), ref, atol=1e-5, rtol=0)


def test_segment_masks_keep_each_segment_on_its_own_text():
    m = _model()
    x, t, _ = _inputs(L=8)
    seg = torch.tensor([[0] * 4 + [1] * 4] * 2)  # (B, L) two segments of 4 tokens
    text_seg = torch.tensor([[0, 0, 1, 1, 1]] * 2)  # (B, S) their texts, concatenated
    cross = segment_cross_mask(seg, text_seg)
    selfm = segment_cross_mask(seg, seg)
    text = torch.randn(2, 5, D_TEXT)
    other = text.clone()
    other[:, 2:] = torch.randn(2, 3, D_TEXT)  # change only segment 1's text
    a = m(x, t, text, cross_mask=cross, self_mask=selfm)
    b = m(x, t, other, cross_mask=cross, self_mask=selfm)
    torch.testing.assert_close(a[:, :4], b[:, :4])  # segment 0 did not see it
    assert not torch.allclose(a[:, 4:], b[:, 4:])
    # Without the masks, segment 0 does see segment 1's text.
    assert not torch.allclose(m(x, t, text)[:, :4], m(x, t, other)[:, :4])


def test_null_condition_replaces_the_text():
    m = _model()
    x, t, text = _inputs()
    drop = torch.tensor([True, False])
    a = m(x, t, text, drop_text=drop)
    b = m(x, t, torch.randn_like(text), drop_text=drop)
    torch.testing.assert_close(a[0], b[0])  # the dropped sample ignores its text
    assert not torch.allclose(a[1], b[1])
    everything = m(x, t, text, drop_text=torch.ones(2, dtype=torch.bool))
    almost_always = m(x, t, text, cond_drop_prob=0.999, generator=torch.Generator().manual_seed(0))
    torch.testing.assert_close(almost_always, everything)
    half = [m(x, t, text, cond_drop_prob=0.5, generator=torch.Generator().manual_seed(0)) for _ in range(2)]
    assert torch.equal(half[0], half[1])
    with pytest.raises(ValueError, match="Generator"):
        m(x, t, text, cond_drop_prob=0.1)


def test_guidance_at_neutral_scale_is_the_conditional_model():
    """M2D2M Eq. 9: (s+1)·log p_c − s·log p_u; s = 0 is the conditional model (VQ-Diffusion's g = 1 + s = 1)."""
    m = _model()
    x, t, text = _inputs()
    log_c = m(x, t, text)
    log_u = m(x, t, text, drop_text=torch.ones(2, dtype=torch.bool))
    torch.testing.assert_close(classifier_free_guidance(log_c, log_u, 0.0), log_c, atol=1e-6, rtol=0)
    s = 3.0
    guided = classifier_free_guidance(log_c, log_u, s)
    vq_style = log_u + (1 + s) * (log_c - log_u)
    torch.testing.assert_close(guided, torch.log_softmax(vq_style, -1), atol=1e-5, rtol=0)
    assert not torch.allclose(guided, log_c, atol=1e-3)


def test_profile_configs():
    full = transformer_config("full")
    assert (full.n_layers, full.n_heads, full.d_model, full.d_ff, full.dropout) == (12, 16, 512, 2048, 0.0)
    assert (full.lr, full.betas, full.weight_decay, full.aux_weight) == (2e-4, (0.9, 0.99), 4.5e-2, 5e-4)
    assert full.timesteps == 100 and full.cond_drop_prob == 0.1
    smoke, laptop = transformer_config("smoke"), transformer_config("laptop")
    assert smoke.d_model < laptop.d_model < full.d_model and smoke.n_layers < laptop.n_layers < full.n_layers
    assert transformer_config("smoke", num_codes=K).num_codes == K
    with pytest.raises(ValueError, match="divisible"):
        transformer_config("smoke", d_model=30, n_heads=4)
    with pytest.raises(ValueError, match="profile"):
        transformer_config("huge")


def test_bad_inputs():
    m = _model()
    x, t, text = _inputs()
    with pytest.raises(ValueError, match="x_t ids"):
        m(x + K + 1, t, text)
    with pytest.raises(ValueError, match="x_t must be"):
        m(x.float(), t, text)
    with pytest.raises(ValueError, match="text must be"):
        m(x, t, text[..., :5])
    with pytest.raises(ValueError, match="t must be in"):
        m(x, t + T + 1, text)
    with pytest.raises(ValueError, match="padding_mask"):
        m(x, t, text, padding_mask=torch.zeros(2, 3, dtype=torch.bool))
    with pytest.raises(ValueError, match="cross_mask"):
        m(x, t, text, cross_mask=torch.ones(2, 7, 3, dtype=torch.bool))


def test_loss_parts_and_decrease_on_a_toy_dataset():
    """Two 'texts', each always paired with one fixed token sequence: a few hundred steps must fit them."""
    cb = torch.randn(K, 3, generator=torch.Generator().manual_seed(1))
    tr = build_transitions(get_schedule(T=T), codebook=cb, eta=1.0)
    m = _model().train()
    seqs = torch.tensor([[0, 1, 2, 3, 4, 5], [7, 6, 5, 4, 3, 2]])
    texts = torch.randn(2, 3, D_TEXT, generator=torch.Generator().manual_seed(2))
    opt = torch.optim.AdamW(m.parameters(), lr=3e-3)
    g = torch.Generator().manual_seed(0)
    losses = []
    for _ in range(250):
        pick = torch.randint(0, 2, (16,), generator=g)
        pad = torch.zeros(16, 6, dtype=torch.bool)
        pad[::4, 5] = True  # some padded tokens too
        out = diffusion_loss(m, tr, seqs[pick], texts[pick], padding_mask=pad, generator=g)
        opt.zero_grad()
        out.loss.backward()
        opt.step()
        losses.append(out.loss.item())
    first, last = sum(losses[:25]) / 25, sum(losses[-25:]) / 25
    assert last < 0.5 * first, (first, last)
    # At t = 1 the bound term is the NLL, equal to the auxiliary term.
    m.eval()
    x0 = seqs
    x_t = torch.full_like(x0, K)
    log_p = m(x_t, torch.tensor([1, 1]), texts)
    vb, aux = vb_terms(log_p, x0, x_t, torch.tensor([1, 1]), tr)
    torch.testing.assert_close(vb, aux)
    with pytest.raises(ValueError, match="x0 must hold"):
        diffusion_loss(m, tr, seqs + K, texts, generator=g)
