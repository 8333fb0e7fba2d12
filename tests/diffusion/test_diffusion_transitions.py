"""Q_t and Q̄_t: stochastic rows, absorbing mask, products, η = 0 = uniform, the sign of η, distances."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from motionlab.diffusion import DISTANCES, build_transitions, codebook_distance, get_schedule

K, T = 6, 8


def _codebook(k: int = K, seed: int = 0) -> torch.Tensor:
    return torch.randn(k, 3, generator=torch.Generator().manual_seed(seed))


@pytest.mark.parametrize("eta,distance", [(0.0, None), (2.0, "l2_rank"), (-3.0, "cosine"), (1.0, "l2")])
def test_rows_are_distributions_and_mask_absorbs(eta, distance):
    cb = None if distance is None else _codebook()
    tr = build_transitions(get_schedule(T=T), num_codes=K, codebook=cb, eta=eta, distance=distance or "l2_rank")
    for mats in (tr.one_step, tr.cumulative):
        assert mats.shape == (T + 1, K + 1, K + 1)
        assert (mats >= 0).all()
        torch.testing.assert_close(mats.sum(-1), torch.ones(T + 1, K + 1), atol=1e-6, rtol=0)
        torch.testing.assert_close(mats[:, K], torch.eye(K + 1)[K].expand(T + 1, -1))  # mask -> mask only
    # The mask mass after t steps is γ̄_t whatever the start code.
    gbar = tr.schedule.gamma_bar.float()
    torch.testing.assert_close(tr.cumulative[:, :K, K], gbar[:, None].expand(T + 1, K), atol=1e-6, rtol=0)


def test_cumulative_products_match_repeated_single_steps():
    tr = build_transitions(get_schedule(T=T), codebook=_codebook(), eta=1.5)
    steps = [tr.matrix64(t).numpy() for t in range(1, T + 1)]
    running = np.eye(K + 1)
    for t in range(1, T + 1):
        running = running @ steps[t - 1]
        np.testing.assert_allclose(tr.cumulative[t].numpy(), running, atol=1e-6)
        np.testing.assert_allclose(tr.one_step[t].numpy(), steps[t - 1], atol=1e-7)
    # interval(s, t) = Q_{s+1}⋯Q_t, and Q̄_s · interval(s, t) = Q̄_t
    np.testing.assert_allclose(tr.interval(2, 6).numpy(), steps[2] @ steps[3] @ steps[4] @ steps[5], atol=1e-6)
    assert torch.equal(tr.interval(4, 5), tr.one_step[5])
    torch.testing.assert_close(tr.cumulative[3] @ tr.interval(3, 8), tr.cumulative[8], atol=1e-6, rtol=0)


@pytest.mark.parametrize("distance", DISTANCES)
def test_eta_zero_reproduces_uniform_exactly(distance):
    uniform = build_transitions(get_schedule(T=T), num_codes=K)
    dynamic = build_transitions(get_schedule(T=T), codebook=_codebook(), eta=0.0, distance=distance)
    assert torch.equal(uniform.one_step, dynamic.one_step)
    assert torch.equal(uniform.cumulative, dynamic.cumulative)
    assert torch.equal(uniform.interval(1, 7), dynamic.interval(1, 7))


def test_positive_eta_favours_far_codes_more_as_t_grows():
    """Paper §4.2: larger distances get larger probability as t advances (η > 0); η < 0 reverses it."""
    cb = _codebook(8)
    rank = codebook_distance(cb, "l2_rank").long()
    for eta, sign in ((2.0, 1), (-2.0, -1)):
        tr = build_transitions(get_schedule(T=T), codebook=cb, eta=eta)
        for t in (1, T // 2, T):
            Q = tr.matrix64(t)[:8, :8] - torch.eye(8, dtype=torch.float64) * tr.schedule.alpha[t]
            by_rank = torch.zeros(8, 8, dtype=torch.float64).scatter_(1, rank, Q)  # row i: β by rank 0..K-1
            diffs = by_rank.diff(dim=1)
            assert (sign * diffs > 0).all()
            ratio = by_rank[:, -1] / by_rank[:, 0]  # farthest / nearest = exp(η·(t/T)·(K−1)/K)
            torch.testing.assert_close(ratio, torch.full((8,), np.exp(eta * t / T * 7 / 8), dtype=torch.float64))
        assert not torch.allclose(tr.one_step[T], tr.one_step[T].T)  # not symmetric


def test_dynamic_beta_needs_a_schedule_with_replacement():
    """With VQ-Diffusion's code default the dynamic matrices are the uniform ones to 1e-6; not so for the paper's."""
    cb = _codebook()
    for name, tiny in (("vqdiffusion_code", True), ("vqdiffusion_paper", False)):
        s = get_schedule(name, T=T)
        gap = build_transitions(s, codebook=cb, eta=2.0).cumulative - build_transitions(s, num_codes=K).cumulative
        assert (gap.abs().max() < 1e-6) == tiny
        if not tiny:
            assert gap.abs().max() > 1e-3


def test_rank_distance_is_a_permutation_with_self_first():
    cb = _codebook(7)
    cb[3] = cb[5]  # a duplicate code: itself must still come first
    for kind in ("l2_rank", "cosine_rank"):
        d = codebook_distance(cb, kind)
        assert torch.equal(d.sort(dim=1).values, torch.arange(7, dtype=torch.float64).expand(7, 7))
        assert torch.equal(d.diagonal(), torch.zeros(7, dtype=torch.float64))
    l2 = codebook_distance(cb, "l2")
    assert l2.max().item() == pytest.approx(7.0) and (l2.diagonal() == 0).all()
    assert torch.allclose(l2, l2.T)


def test_memory_is_reported():
    tr = build_transitions(get_schedule(T=T), num_codes=K)
    assert tr.nbytes == 2 * (T + 1) * (K + 1) ** 2 * 4


def test_bad_inputs():
    s = get_schedule(T=T)
    with pytest.raises(ValueError, match="needs a codebook"):
        build_transitions(s, num_codes=K, eta=0.5)
    with pytest.raises(ValueError, match="num_codes"):
        build_transitions(s)
    with pytest.raises(ValueError, match="disagrees"):
        build_transitions(s, num_codes=K + 1, codebook=_codebook())
    with pytest.raises(ValueError, match="distance must be"):
        codebook_distance(_codebook(), "manhattan")
    with pytest.raises(ValueError, match=r"\(K, D\)"):
        codebook_distance(torch.randn(5), "l2")
    tr = build_transitions(s, num_codes=K)
    with pytest.raises(ValueError, match="0 <= s < t"):
        tr.interval(5, 5)


def test_keep_and_mask_completes_a_replacement_block():
    from motionlab.diffusion.transitions import keep_and_mask, uniform_matrix

    schedule, K, t = get_schedule(T=20), 5, 7
    block = torch.zeros(K + 1, K + 1, dtype=torch.float64)
    block[:K, :K] = schedule.kbeta[t] / K
    Q = keep_and_mask(block.clone(), schedule, t)
    assert torch.equal(Q, uniform_matrix(schedule, t, K))
    assert torch.allclose(Q.diagonal()[:K], schedule.alpha[t] + schedule.kbeta[t] / K)
    assert torch.all(Q[:K, K] == schedule.gamma[t]) and Q[K].tolist() == [0.0] * K + [1.0]
    assert torch.allclose(Q.sum(1), torch.ones(K + 1, dtype=torch.float64))
