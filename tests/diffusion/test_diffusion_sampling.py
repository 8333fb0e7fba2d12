"""Samplers: grids, truncation mass, guidance, fast sampling shapes, padding, determinism."""

from __future__ import annotations

import pytest
import torch

from motionlab.diffusion import (
    DenoisingTransformer,
    build_transitions,
    denoise_step,
    get_schedule,
    gumbel_sample,
    log_p_posterior,
    sample,
    timestep_grid,
    transformer_config,
    truncate,
)

K, D_TEXT, T = 8, 12, 10


@pytest.fixture(scope="module")
def setup():
    cfg = transformer_config("smoke", num_codes=K, text_dim=D_TEXT, timesteps=T)
    model = DenoisingTransformer(cfg, seed=0).eval()
    cb = torch.randn(K, 3, generator=torch.Generator().manual_seed(1))
    tr = build_transitions(get_schedule(T=T), codebook=cb, eta=0.5)
    text = torch.randn(3, 4, D_TEXT, generator=torch.Generator().manual_seed(2))
    return model, tr, text


def test_timestep_grid():
    assert timestep_grid(10) == list(range(10, -1, -1))
    assert timestep_grid(100, 10) == list(range(100, -1, -10))
    grid = timestep_grid(100, 7)
    assert grid[0] == 100 and grid[-1] == 0 and len(grid) == 8 and grid == sorted(grid, reverse=True)
    with pytest.raises(ValueError, match="num_steps"):
        timestep_grid(10, 11)


def test_top_p_keeps_the_smallest_prefix_with_enough_mass():
    probs = torch.tensor([[0.5, 0.05, 0.3, 0.15], [0.97, 0.01, 0.01, 0.01]])
    out = truncate(probs.log(), top_p=0.85).exp()
    # Row 0: 0.5 + 0.3 = 0.8 < 0.85, so 0.15 joins; 0.05 goes. Row 1: the top class alone holds 0.97.
    torch.testing.assert_close(out[0], torch.tensor([0.5, 0.0, 0.3, 0.15]) / 0.95, atol=1e-6, rtol=0)
    torch.testing.assert_close(out[1], torch.tensor([1.0, 0.0, 0.0, 0.0]), atol=1e-6, rtol=0)
    g = torch.Generator().manual_seed(0)
    log_p = torch.log_softmax(2 * torch.randn(50, 20, generator=g), -1)
    for p in (0.3, 0.85, 0.99):
        kept = truncate(log_p, top_p=p).exp() > 1e-20
        mass = (log_p.exp() * kept).sum(-1)
        assert (mass >= p - 1e-6).all()
        smallest_kept = torch.where(kept, log_p.exp(), torch.inf).min(-1).values
        assert (mass - smallest_kept < p).all()  # dropping the least likely kept class would fall short
    assert torch.equal(truncate(log_p), log_p)


def test_top_k_and_both():
    log_p = torch.log_softmax(torch.tensor([[3.0, 1.0, 2.0, 0.0, -1.0]]), -1)
    out = truncate(log_p, top_k=2).exp()
    assert (out > 1e-20).sum() == 2 and out[0, [0, 2]].sum().item() == pytest.approx(1.0)
    both = truncate(log_p, top_p=0.5, top_k=3).exp()
    assert (both > 1e-20).sum() == 1
    with pytest.raises(ValueError, match="top_k"):
        truncate(log_p, top_k=0)
    with pytest.raises(ValueError, match="top_p"):
        truncate(log_p, top_p=1.5)


@pytest.mark.parametrize("num_steps", [None, 3, 1])
def test_sampling_shapes_and_padding(setup, num_steps):
    model, tr, text = setup
    ids = sample(
        model,
        tr,
        text,
        lengths=[5, 9, 2],
        generator=torch.Generator().manual_seed(0),
        num_steps=num_steps,
        guidance_scale=2.0,
        top_p=0.9,
    )
    assert ids.shape == (3, 9) and ids.dtype == torch.long
    valid = torch.arange(9)[None] < torch.tensor([5, 9, 2])[:, None]
    assert ((ids >= 0) & (ids < K))[valid].all()
    assert (ids[~valid] == -1).all()


def test_sampling_is_deterministic_under_a_seed(setup):
    model, tr, text = setup

    def run(seed, **kw):
        g = torch.Generator().manual_seed(seed)
        return sample(model, tr, text, lengths=[6, 6, 6], generator=g, num_steps=4, **kw)

    assert torch.equal(run(0), run(0))
    assert not torch.equal(run(0), run(1))
    assert torch.equal(run(3, guidance_scale=2.0, top_k=3), run(3, guidance_scale=2.0, top_k=3))


class Recording(torch.nn.Module):
    """The denoiser, keeping each call's ``drop_text`` and output (to build a step's draw by hand)."""

    def __init__(self, model):
        super().__init__()
        self.model, self.calls = model, []

    def forward(self, *args, **kw):
        out = self.model(*args, **kw)
        self.calls.append((kw.get("drop_text"), out.float()))
        return out


def test_neutral_guidance_matches_the_conditional_sampler(setup):
    """s = 0 needs no unconditional pass; both guidance spaces then coincide with the conditional sampler."""
    model, tr, text = setup
    x = torch.full((3, 6), K)
    draws = []
    for space in ("x0", "posterior"):
        recording = Recording(model)
        draws.append(
            denoise_step(
                recording,
                tr,
                x,
                T,
                T - 3,
                text,
                generator=torch.Generator().manual_seed(0),
                guidance_scale=0.0,
                guidance_on=space,
            )
        )
        ((drop, log_c),) = recording.calls  # one call, conditional only
        assert drop is None or not drop.any()
        posterior = log_p_posterior(log_c, x, tr.interval(T - 3, T), tr.cumulative[T - 3], tr.cumulative[T])
        assert torch.equal(draws[-1], gumbel_sample(posterior, torch.Generator().manual_seed(0)))
    assert torch.equal(draws[0], draws[1])
    guided = [
        denoise_step(model, tr, x, T, 0, text, generator=torch.Generator().manual_seed(s), guidance_scale=5.0)
        for s in range(4)
    ]
    plain = [denoise_step(model, tr, x, T, 0, text, generator=torch.Generator().manual_seed(s)) for s in range(4)]
    assert any(not torch.equal(a, b) for a, b in zip(guided, plain, strict=True))


def test_denoise_step_contract(setup):
    model, tr, text = setup
    x = torch.full((3, 6), K)
    pad = torch.zeros(3, 6, dtype=torch.bool)
    pad[0, 4:] = True
    g = torch.Generator().manual_seed(0)
    mid = denoise_step(model, tr, x, T, 5, text, generator=g, padding_mask=pad)
    assert (mid[pad] == K).all() and mid.shape == (3, 6)
    last = denoise_step(model, tr, mid, 5, 0, text, generator=g, padding_mask=pad)
    assert (last[~pad] < K).all()  # x_0 holds codes only
    with pytest.raises(ValueError, match="t_prev"):
        denoise_step(model, tr, x, 3, 3, text, generator=g)
    with pytest.raises(ValueError, match="guidance_on"):
        denoise_step(model, tr, x, 3, 2, text, generator=g, guidance_on="z")
    with pytest.raises(ValueError, match="generator"):
        denoise_step(model, tr, x, 3, 2, text, generator=None)


def test_bad_sampling_inputs(setup):
    model, tr, text = setup
    g = torch.Generator().manual_seed(0)
    with pytest.raises(ValueError, match="lengths"):
        sample(model, tr, text, lengths=[3, 3], generator=g)
    with pytest.raises(ValueError, match="lengths"):
        sample(model, tr, text, lengths=[3, 0, 2], generator=g)
    with pytest.raises(ValueError, match="timesteps"):
        sample(model, tr, text, lengths=[3, 3, 3], generator=g, timesteps=[10, 5, 5, 0])
    with pytest.raises(ValueError, match="timesteps"):
        sample(model, tr, text, lengths=[3, 3, 3], generator=g, timesteps=[9, 0])


@pytest.mark.parametrize("guided", [False, True])
def test_network_runs_on_length_groups_with_the_same_result(setup, guided):
    """Rows grouped by length and cropped give what one call over the padded batch gives at real positions."""
    from motionlab.diffusion import sampling

    model, tr, _ = setup
    g = torch.Generator().manual_seed(5)
    lengths = torch.tensor([3, 9, 1, 6, 9, 2, 5])
    B, L = len(lengths), int(lengths.max()) + 2  # two columns of padding even in the longest row
    padding = torch.arange(L)[None, :] >= lengths[:, None]
    x = torch.randint(0, K + 1, (B, L), generator=g).masked_fill(padding, K)
    text = torch.randn(B, 4, D_TEXT, generator=g)
    text_pad = torch.zeros(B, 4, dtype=torch.bool)
    text_pad[0, 2:] = True
    kw = dict(text_padding_mask=text_pad, padding_mask=padding, cross_mask=None, self_mask=None)
    with torch.no_grad():
        whole = sampling._network_log_p_x0(model, x, 7, text, guided, **kw)
        for rows in (3, 32):  # several groups; one group cropped to the longest row
            grouped = sampling._model_log_p_x0(model, x, 7, text, guided, rows_per_call=rows, **kw)
            for a, b in zip(grouped, whole):
                if b is None:
                    assert a is None
                    continue
                torch.testing.assert_close(a[~padding], b[~padding], atol=1e-5, rtol=1e-5)
                assert torch.allclose(a[padding].exp().sum(-1), torch.ones(int(padding.sum())))


def test_grouped_sampling_keeps_every_row_its_own_length(setup, monkeypatch):
    from motionlab.diffusion import sampling

    model, tr, _ = setup
    lengths = [4, 1, 7, 2, 7, 3]
    text = torch.randn(len(lengths), 4, D_TEXT, generator=torch.Generator().manual_seed(3))
    monkeypatch.setattr(sampling, "ROWS_PER_CALL", 2)
    ids = sample(
        model, tr, text, lengths=lengths, generator=torch.Generator().manual_seed(0), num_steps=4, guidance_scale=2.0
    )
    for row, n in zip(ids, lengths):
        assert (row[:n] >= 0).all() and (row[:n] < K).all() and (row[n:] == -1).all()


def test_denoise_step_is_the_network_then_reverse_step(setup):
    """The wrapper adds the network call (twice when guided), devices and padding; the step itself is reverse_step."""
    from motionlab.diffusion.sampling import reverse_step

    model, tr, text = setup
    x = torch.full((3, 6), K)
    x[1, :2] = torch.tensor([1, 5])
    for kw in (dict(), dict(guidance_scale=3.0), dict(guidance_scale=2.0, guidance_on="posterior", top_p=0.8)):
        for t, t_prev in ((T, T - 1), (T, 4), (6, 0)):
            recording = Recording(model)
            step = denoise_step(recording, tr, x, t, t_prev, text, generator=torch.Generator().manual_seed(1), **kw)
            ((drop, out),) = recording.calls  # one network call: with and without the text in one batch
            guided = kw.get("guidance_scale", 0.0) != 0.0
            log_c, log_u = (out[:3], out[3:]) if guided else (out, None)
            if guided:  # the second half of the batch runs without the text
                assert drop[3:].all() and not drop[:3].any()
            direct = reverse_step(tr, log_c, x, t, t_prev, torch.Generator().manual_seed(1), log_p_x0_null=log_u, **kw)
            assert torch.equal(step, direct), (kw, t, t_prev)


def test_reverse_step_to_zero_draws_from_the_prediction_itself(setup):
    """At t_prev = 0 there is no posterior to mix: the draw is from p_θ(x_0 | x_t), so a certain prediction wins."""
    from motionlab.diffusion.sampling import reverse_step

    _, tr, _ = setup
    x = torch.full((2, 5), K)
    certain = torch.full((2, 5, K), -70.0)
    certain[..., 3] = 0.0
    assert (reverse_step(tr, certain, x, T, 0, torch.Generator().manual_seed(0)) == 3).all()
    # one step earlier the posterior mostly keeps the mask (γ̄_{T-1} / γ̄_T = 0.9 here), and unmasks to the predicted code
    many, masked = certain[:1].expand(100, 5, K), x[:1].expand(100, 5)
    drawn = reverse_step(tr, many, masked, T, T - 1, torch.Generator().manual_seed(0))
    counts = torch.bincount(drawn.flatten(), minlength=K + 1)
    assert 0.8 < counts[K] / drawn.numel() < 0.97 and counts[:K].argmax() == 3
