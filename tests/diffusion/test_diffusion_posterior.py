"""Posteriors against Bayes' rule by brute-force enumeration of paths (K = 5, T = 6)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import torch

from motionlab.diffusion import (
    LOG_FLOOR,
    build_transitions,
    get_schedule,
    linear_schedule,
    log_p_posterior,
    log_q_posterior,
    log_q_xt_given_x0,
    q_sample,
)

K, T = 5, 6


def _transitions(eta: float):
    cb = torch.randn(K, 2, generator=torch.Generator().manual_seed(3))
    return build_transitions(get_schedule(T=T), codebook=cb, eta=eta)


def _brute_force_joint(steps: list[np.ndarray], x0: int, t: int) -> np.ndarray:
    """q(x_{t-1} = a, x_t = b | x_0) by summing the probability of every path x_1 … x_t."""
    joint = np.zeros((K + 1, K + 1))
    for path in itertools.product(range(K + 1), repeat=t):
        p, prev = 1.0, x0
        for k, state in enumerate(path):
            p *= steps[k][prev, state]
            prev = state
        joint[path[-2] if t > 1 else x0, path[-1]] += p
    return joint


@pytest.mark.parametrize("eta", [0.0, 2.5])
def test_posterior_equals_bayes_rule_by_enumeration(eta):
    tr = _transitions(eta)
    steps = [tr.matrix64(t).numpy() for t in range(1, T + 1)]
    x0 = torch.arange(K).repeat_interleave(K + 1)[None]  # every (x0, x_t) pair in one batch row
    x_t = torch.arange(K + 1).repeat(K)[None]
    for t in range(1, 5):  # (K+1)^t paths: up to 1296
        got = log_q_posterior(x0, x_t, tr.one_step[t], tr.cumulative[t - 1]).exp()[0].numpy()
        for n, (a, b) in enumerate(zip(x0[0].tolist(), x_t[0].tolist(), strict=True)):
            joint = _brute_force_joint(steps, a, t)
            if joint[:, b].sum() == 0:
                continue  # x_t impossible from x0 (e.g. mask at t = 0)
            np.testing.assert_allclose(got[n], joint[:, b] / joint[:, b].sum(), atol=2e-6)


@pytest.mark.parametrize("eta", [0.0, 2.5])
def test_reverse_step_is_the_mixture_of_posteriors(eta):
    tr = _transitions(eta)
    g = torch.Generator().manual_seed(0)
    B, L = 3, 4
    log_p_x0 = torch.log_softmax(3 * torch.randn(B, L, K, generator=g), dim=-1)
    for t in (1, 2, T):
        x_t = q_sample(torch.randint(0, K, (B, L), generator=g), tr.cumulative[t], g)
        got = log_p_posterior(log_p_x0, x_t, tr.one_step[t], tr.cumulative[t - 1], tr.cumulative[t])
        torch.testing.assert_close(got.exp().sum(-1), torch.ones(B, L), atol=1e-5, rtol=0)
        mix = torch.zeros(B, L, K + 1)
        for k in range(K):
            q = log_q_posterior(torch.full((B, L), k), x_t, tr.one_step[t], tr.cumulative[t - 1]).exp()
            mix += log_p_x0[..., k : k + 1].exp() * q
        torch.testing.assert_close(got.exp(), mix, atol=1e-5, rtol=0)
    # a one-hot p(x0) gives back the true posterior
    x0 = torch.randint(0, K, (B, L), generator=g)
    one_hot = torch.full((B, L, K), LOG_FLOOR).scatter(-1, x0[..., None], 0.0)
    x_t = q_sample(x0, tr.cumulative[3], g)
    torch.testing.assert_close(
        log_p_posterior(one_hot, x_t, tr.one_step[3], tr.cumulative[2], tr.cumulative[3]).exp(),
        log_q_posterior(x0, x_t, tr.one_step[3], tr.cumulative[2]).exp(),
        atol=1e-5,
        rtol=0,
    )


def test_per_sample_matrices_equal_shared_ones():
    tr = _transitions(1.0)
    g = torch.Generator().manual_seed(1)
    x0 = torch.randint(0, K, (2, 5), generator=g)
    t = torch.tensor([2, 5])
    x_t = torch.stack([q_sample(x0[i : i + 1], tr.cumulative[int(t[i])], g)[0] for i in range(2)])
    batched = log_q_posterior(x0, x_t, tr.one_step[t], tr.cumulative[t - 1])
    for i in range(2):
        single = log_q_posterior(x0[i : i + 1], x_t[i : i + 1], tr.one_step[int(t[i])], tr.cumulative[int(t[i]) - 1])
        torch.testing.assert_close(batched[i : i + 1], single)


def test_jump_posterior_equals_chained_single_step_posteriors():
    """Fast sampling's jump t -> s is exact: q(x_s | x_t, x0) = Σ_paths Π q(x_{k-1} | x_k, x0)."""
    tr = _transitions(2.0)
    s, t = 1, 4
    for x0 in range(K):
        for x_t in range(K + 1):
            ids0, idst = torch.tensor([[x0]]), torch.tensor([[x_t]])
            if tr.cumulative[t][x0, x_t] == 0:
                continue
            jump = log_q_posterior(ids0, idst, tr.interval(s, t), tr.cumulative[s]).exp()[0, 0]
            dist = torch.zeros(K + 1)
            dist[x_t] = 1.0
            for k in range(t, s, -1):  # push the distribution over x_k back to x_{k-1}
                post = log_q_posterior(
                    ids0.expand(1, K + 1), torch.arange(K + 1)[None], tr.one_step[k], tr.cumulative[k - 1]
                ).exp()[0]  # (K+1 values of x_k, K+1 of x_{k-1})
                dist = dist @ post
            torch.testing.assert_close(jump, dist, atol=1e-5, rtol=0)


def test_forward_sampling_matches_marginals_and_is_seeded():
    tr = _transitions(2.0)
    x0 = torch.full((1, 20000), 2)
    draws = q_sample(x0, tr.cumulative[3], torch.Generator().manual_seed(0))
    freq = torch.bincount(draws[0], minlength=K + 1).double() / 20000
    torch.testing.assert_close(freq, tr.cumulative[3][2].double(), atol=0.012, rtol=0)
    again = q_sample(x0, tr.cumulative[3], torch.Generator().manual_seed(0))
    assert torch.equal(draws, again)
    lq = log_q_xt_given_x0(torch.tensor([[0, 4]]), tr.cumulative[6])
    torch.testing.assert_close(lq.exp()[0], tr.cumulative[6][[0, 4]])


def test_bad_inputs():
    tr = _transitions(0.0)
    x = torch.zeros(2, 3, dtype=torch.long)
    with pytest.raises(ValueError, match="x_t must be"):
        log_q_posterior(x, x.float(), tr.one_step[1], tr.cumulative[0])
    with pytest.raises(ValueError, match="x0 must hold"):
        log_q_posterior(x + K, x, tr.one_step[1], tr.cumulative[0])
    with pytest.raises(ValueError, match="step must be"):
        log_q_posterior(x, x, tr.one_step[1:4], tr.cumulative[0])
    with pytest.raises(ValueError, match="log_p_x0 must be"):
        log_p_posterior(torch.zeros(2, 3, K + 1), x, tr.one_step[1], tr.cumulative[0], tr.cumulative[1])
    with pytest.raises(ValueError, match="generator is required"):
        q_sample(x, tr.cumulative[1], None)


def test_zero_probability_transitions_under_pure_masking():
    """With K·β̄ = 0 (absorbing only) a visible code at t was the code at t−1, whatever p(x0) says."""
    absorbing = linear_schedule(T, (1 - 1 / T, 0.0), (1 / T, 1.0))
    assert absorbing.kbeta_bar.abs().max() < 1e-12
    tr = build_transitions(absorbing, num_codes=K)
    g = torch.Generator().manual_seed(0)
    log_p_x0 = torch.log_softmax(torch.randn(1, K + 1, K, generator=g), dim=-1)
    x_t = torch.arange(K + 1)[None]  # every code, then the mask
    for t in (2, 4):
        got = log_p_posterior(log_p_x0, x_t, tr.one_step[t], tr.cumulative[t - 1], tr.cumulative[t]).exp()[0]
        torch.testing.assert_close(got[:K], torch.eye(K, K + 1), atol=1e-6, rtol=0)
        # masked at t: unmasked at t−1 with probability (γ̄_t − γ̄_{t−1}) / γ̄_t, spread as p(x0)
        unmask = (absorbing.gamma_bar[t] - absorbing.gamma_bar[t - 1]) / absorbing.gamma_bar[t]
        expected = torch.cat([unmask * log_p_x0[0, K].exp().double(), (1 - unmask)[None]]).float()
        torch.testing.assert_close(got[K], expected, atol=1e-6, rtol=0)
        q = log_q_posterior(torch.tensor([[1, 1]]), torch.tensor([[1, 3]]), tr.one_step[t], tr.cumulative[t - 1])
        assert q[0, 0, 1].exp() == pytest.approx(1.0) and torch.isfinite(q).all()  # x_t = 3 impossible: floored


def test_gradients_stay_finite_where_probabilities_are_zero():
    tr = build_transitions(linear_schedule(T, (1 - 1 / T, 0.0), (1 / T, 1.0)), num_codes=K)
    logits = torch.randn(1, K + 1, K, requires_grad=True)
    x_t = torch.arange(K + 1)[None]
    out = log_p_posterior(torch.log_softmax(logits, -1), x_t, tr.one_step[1], tr.cumulative[0], tr.cumulative[1])
    (out * torch.randn_like(out)).sum().backward()
    assert torch.isfinite(logits.grad).all() and logits.grad.abs().sum() > 0
