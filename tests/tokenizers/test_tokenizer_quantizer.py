"""QuantizerEMAReset invariants."""

import pytest
import torch

from motionlab.tokenizers import QuantizerEMAReset, perplexity_of


def gen(seed=0):
    return torch.Generator().manual_seed(seed)


def test_output_is_a_codebook_row_and_eval_is_argmin():
    q = QuantizerEMAReset(codebook_size=8, code_dim=4).eval()
    x = torch.randn(3, 5, 4, generator=gen())
    out = q(x)
    assert out.ids.shape == (3, 5) and out.quantized.shape == x.shape
    assert torch.equal(out.codes, q.codebook[out.ids])
    assert torch.allclose(out.quantized, out.codes, atol=1e-6)
    brute = torch.cdist(x.reshape(-1, 4), q.codebook).argmin(-1).reshape(3, 5)
    assert torch.equal(out.ids, brute) and torch.equal(q.quantize(x), brute)
    before = q.codebook.clone()
    q(x)
    assert torch.equal(q.codebook, before)  # eval never updates the codebook


def test_straight_through_gradient_reaches_the_input():
    q = QuantizerEMAReset(8, 4).eval()
    x = torch.randn(6, 4, generator=gen(), requires_grad=True)
    weights = torch.randn(6, 4, generator=gen(1))
    (q(x).quantized * weights).sum().backward()
    assert torch.allclose(x.grad, weights)  # d quantized / d x = identity
    x.grad = None
    out = q(x)
    out.commit_loss.backward()  # MSE(x, sg(c)) moves x towards its code
    assert torch.allclose(x.grad, 2 * (x - out.codes).detach() / x.numel())


def test_first_training_batch_initialises_the_codebook():
    q = QuantizerEMAReset(8, 4)
    random_init = q.codebook.clone()
    x = torch.randn(20, 4, generator=gen())
    q.init_codebook(x, gen())
    assert torch.cdist(q.codebook, x).min(-1).values.max() < 1e-6  # every code is a batch vector
    assert len(torch.unique(q.codebook, dim=0)) == 8  # ... and they are distinct
    few = torch.randn(3, 4, generator=gen(1))  # fewer vectors than codes: repeated with a small jitter
    q.init_codebook(few, gen())
    assert torch.cdist(q.codebook, few).min(-1).values.max() < 0.1
    assert len(torch.unique(q.codebook, dim=0)) == 8

    fresh = QuantizerEMAReset(8, 4)
    assert not fresh.initialized
    fresh(x, gen())  # a training forward initialises first
    assert fresh.initialized and not torch.equal(fresh.codebook, random_init)


def test_ema_moves_code_towards_assigned_mean():
    q = QuantizerEMAReset(4, 2, decay=0.9, reset_threshold=0.0)
    q.codebook.copy_(torch.tensor([[0.0, 0.0], [10.0, 10.0], [-10.0, 10.0], [10.0, -10.0]]))
    q.code_sum.copy_(q.codebook)
    q.initialized.fill_(True)
    x = torch.tensor([[1.0, 1.0], [2.0, 0.0], [1.5, 0.5]])  # all nearest to code 0, mean (1.5, 0.5)
    out = q(x, gen())
    assert torch.all(out.ids == 0)
    expected = (0.9 * torch.zeros(2) + 0.1 * x.sum(0)) / (0.9 * 1.0 + 0.1 * 3)
    assert torch.allclose(q.codebook[0], expected)
    mean = x.mean(0)
    assert (q.codebook[0] - mean).norm() < mean.norm()  # closer to the mean than before
    assert torch.allclose(q.codebook[1:], torch.tensor([[10.0, 10.0], [-10.0, 10.0], [10.0, -10.0]]))


def test_dead_codes_are_reset_to_current_encoder_outputs():
    q = QuantizerEMAReset(4, 2, decay=0.99, reset_threshold=1.0)
    q.codebook.copy_(torch.tensor([[0.0, 0.0], [100.0, 100.0], [-100.0, 100.0], [100.0, -100.0]]))
    q.code_sum.copy_(q.codebook)
    q.initialized.fill_(True)
    x = torch.randn(64, 2, generator=gen()) * 0.1  # all near code 0: codes 1-3 starve
    q(x, gen())
    assert q.code_count[0] >= 1.0 and torch.all(q.code_count[1:] < 1.0)
    for k in (1, 2, 3):  # each dead code is now one of the batch vectors
        assert torch.cdist(q.codebook[k : k + 1], x).min() < 1e-6


def test_reset_is_reproducible_with_the_same_generator():
    def run(seed):
        q = QuantizerEMAReset(16, 3)
        x = torch.randn(40, 3, generator=gen(5))
        for _ in range(3):
            q(x, gen(seed))
        return q.codebook.clone()

    assert torch.equal(run(0), run(0))
    assert not torch.equal(run(0), run(1))


def test_perplexity_bounds():
    assert perplexity_of(torch.zeros(10, dtype=torch.long), 8).item() == pytest.approx(1.0)
    assert perplexity_of(torch.arange(8).repeat(3), 8).item() == pytest.approx(8.0)
    q = QuantizerEMAReset(32, 4).eval()
    out = q(torch.randn(20, 4, generator=gen()))
    assert 1.0 <= out.perplexity.item() <= 20.0 + 1e-4
    assert 0 < out.usage.item() <= 20 / 32


def test_gumbel_sampling_only_in_training():
    q = QuantizerEMAReset(16, 4, gumbel_temperature=5.0, decay=0.99)
    x = torch.randn(200, 4, generator=gen())
    q(x, gen())  # initialise
    q.decay = 1.0 - 1e-9  # freeze the codebook so only the sampling differs
    argmin = q.quantize(x)
    sampled = q(x, gen(1)).ids
    assert (sampled != argmin).any()
    assert torch.equal(q(x, gen(1)).ids, sampled)  # seeded
    assert torch.equal(q.eval()(x).ids, argmin)


def test_bad_construction():
    with pytest.raises(ValueError):
        QuantizerEMAReset(1, 4)
    with pytest.raises(ValueError):
        QuantizerEMAReset(8, 4, decay=1.0)
