"""ResidualVQ: residuals shrink, quantize dropout keeps a prefix, −1 means "no code"."""

import pytest
import torch

from motionlab.tokenizers import ResidualVQ


def gen(seed=0):
    return torch.Generator().manual_seed(seed)


def fitted_rvq(num_layers=4, dropout=0.0):
    rvq = ResidualVQ(num_layers, codebook_size=32, code_dim=6, quantize_dropout=dropout)
    z = torch.randn(256, 6, generator=gen())
    g = gen(1)
    for _ in range(5):  # initialise every layer's codebook from its residuals and let the EMA settle
        rvq(z, g)
    return rvq.eval(), z


def test_residual_norm_decreases_with_layers():
    rvq, z = fitted_rvq()
    ids = rvq.quantize(z)
    norms = []
    for k in range(rvq.num_layers + 1):
        approx = rvq.codes_to_latent(ids, num_layers=k) if k else torch.zeros_like(z)
        norms.append((z - approx).norm(dim=-1).mean().item())
    assert all(a > b for a, b in zip(norms, norms[1:])), norms


def test_forward_sums_layers_and_matches_quantize():
    rvq, z = fitted_rvq()
    out = rvq(z)
    assert out.ids.shape == (256, 4) and out.perplexity.shape == (4,)
    assert torch.equal(out.ids, rvq.quantize(z))
    assert torch.allclose(out.codes, rvq.get_codes_from_indices(out.ids).sum(0))
    assert torch.allclose(out.quantized, out.codes, atol=1e-5)
    zg = z.clone().requires_grad_(True)
    rvq(zg).quantized.sum().backward()
    assert torch.allclose(zg.grad, torch.ones_like(z))  # one straight-through for the sum


def test_quantize_dropout_keeps_a_prefix_and_marks_the_rest():
    rvq = ResidualVQ(4, 16, 6, quantize_dropout=1.0)
    z = torch.randn(10, 3, 6, generator=gen())
    g, kept = gen(2), set()
    for _ in range(40):
        ids = rvq(z, g).ids  # (10, 3, 4)
        valid = ids >= 0
        n = int(valid[0, 0].sum())
        assert torch.all(valid[..., :n]) and torch.all(ids[..., n:] == -1)  # same prefix for the whole batch
        kept.add(n)
    assert kept == {1, 2, 3, 4}
    rvq.quantize_dropout = 0.0
    assert torch.all(rvq(z, g).ids >= 0)
    rvq.quantize_dropout = 1.0
    assert torch.all(rvq.eval()(z).ids >= 0)  # never at eval


def rule_draw(generator, p, num_layers):
    """The layer-dropout rule as written: the depth is drawn only when a layer is dropped."""
    if torch.rand((), generator=generator) < p:
        return int(torch.randint(1, num_layers + 1, (), generator=generator))
    return num_layers


@pytest.mark.parametrize("p", [0.2, 0.5, 1.0])
def test_the_one_read_draw_follows_the_rule_and_its_generator(p):
    rvq = ResidualVQ(6, 8, 4, quantize_dropout=p)
    ours, rule = gen(7), gen(7)
    draws = [rvq.active_layers(ours) for _ in range(300)]
    assert draws == [rule_draw(rule, p, 6) for _ in range(300)]
    assert torch.equal(ours.get_state(), rule.get_state())  # later draws (codebook resets) are unchanged too
    assert set(draws) == {1, 2, 3, 4, 5, 6}


def test_no_layer_dropout_draws_nothing():
    g = gen(7)
    state = g.get_state()
    assert ResidualVQ(6, 8, 4, quantize_dropout=0.0).active_layers(g) == 6
    assert ResidualVQ(1, 8, 4, quantize_dropout=0.5).active_layers(g) == 1
    assert torch.equal(g.get_state(), state)


def test_get_codes_from_indices_with_missing_layers():
    rvq, z = fitted_rvq(3)
    ids = torch.tensor([[3, -1, 5], [-1, -1, -1]])
    codes = rvq.get_codes_from_indices(ids)  # (3, 2, 6)
    assert codes.shape == (3, 2, 6)
    assert torch.equal(codes[0, 0], rvq.layers[0].codebook[3]) and torch.equal(codes[2, 0], rvq.layers[2].codebook[5])
    assert torch.all(codes[1] == 0) and torch.all(codes[:, 1] == 0)
    assert torch.allclose(rvq.codes_to_latent(ids), codes.sum(0))
    assert torch.allclose(rvq.codes_to_latent(ids[:, :1]), codes[0])  # fewer layers given


def test_codebooks_are_not_shared():
    rvq, _ = fitted_rvq(3)
    assert not torch.equal(rvq.layers[0].codebook, rvq.layers[1].codebook)


def test_bad_construction():
    with pytest.raises(ValueError, match="num_layers"):
        ResidualVQ(0, 8, 4)
    with pytest.raises(ValueError, match="quantize_dropout"):
        ResidualVQ(2, 8, 4, quantize_dropout=1.5)
