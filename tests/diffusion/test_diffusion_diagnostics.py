"""Diagnostics of a trained model: token statistics, entropy of p(x0 | x_t) under guidance, forward-process TV."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
import torch
from torch import nn

from motionlab.diffusion import (
    adjacent_repeat_rate,
    build_transitions,
    classifier_free_guidance,
    code_entropy,
    code_histogram,
    dynamic_uniform_tv,
    forward_tv,
    get_schedule,
    histogram_tv,
    token_rows,
    x0_entropy,
)
from motionlab.diffusion.diagnostics import token_statistics
from motionlab.estimate import Estimate
from motionlab.studies.diffusion_diagnostics import MarkdownTable, eta_distances

K, T = 6, 8
ROWS = torch.tensor([[0, 0, 1, 2, 2, 2], [3, 3, -1, -1, -1, -1], [5, 4, 5, -1, -1, -1]])


# ------------------------------------------------------------------------------------------ token ids


def test_token_rows_pads_sequences_and_checks_tensors():
    rows = token_rows([torch.tensor([1, 2, 3]), torch.tensor([4])])
    assert rows.tolist() == [[1, 2, 3], [4, -1, -1]]
    assert torch.equal(token_rows(ROWS), ROWS)
    with pytest.raises(ValueError, match="ids"):
        token_rows(torch.zeros(2, 3))
    with pytest.raises(ValueError, match="ids"):
        token_rows([])


def test_histogram_entropy_and_tv_match_counting_by_hand():
    codes = [c for c in ROWS.flatten().tolist() if c >= 0]
    counts = Counter(codes)
    expected = torch.tensor([counts[k] / len(codes) for k in range(K)], dtype=torch.float64)
    torch.testing.assert_close(code_histogram(ROWS, K), expected)
    assert code_entropy(ROWS, K) == pytest.approx(-sum(p * math.log(p) for p in expected.tolist() if p > 0))

    other = torch.tensor([[0, 1, 1, 1]])
    q = [Counter([0, 1, 1, 1])[k] / 4 for k in range(K)]
    assert histogram_tv(ROWS, other, K) == pytest.approx(0.5 * sum(abs(a - b) for a, b in zip(expected.tolist(), q)))
    assert histogram_tv(ROWS, ROWS, K) == 0.0
    assert histogram_tv(torch.tensor([[0, 0]]), torch.tensor([[1, 2]]), K) == pytest.approx(1.0)  # disjoint
    with pytest.raises(ValueError, match="num_codes"):
        code_histogram(ROWS, 5)
    with pytest.raises(ValueError, match="padding"):
        code_histogram(torch.full((1, 3), -1), K)


def test_adjacent_repeat_rate_counts_pairs_inside_sequences_only():
    # pairs: row 0: (0,0) (0,1) (1,2) (2,2) (2,2) -> 3 repeats of 5; row 1: (3,3) -> 1 of 1; row 2: 0 of 2.
    assert adjacent_repeat_rate(ROWS) == pytest.approx(4 / 8)
    # A repeat across the end of one sequence and the start of the next never counts.
    assert adjacent_repeat_rate([torch.tensor([1, 2]), torch.tensor([2, 3])]) == 0.0
    with pytest.raises(ValueError, match="pair"):
        adjacent_repeat_rate([torch.tensor([1]), torch.tensor([2])])


# ------------------------------------------------------------------------------------ p_θ(x_0 | x_t)


class FixedDenoiser(nn.Module):
    """Ignores its input: log p(x0 | x_t, y) = log_softmax(cond), with ∅: log_softmax(uncond), at every position."""

    def __init__(self, cond: torch.Tensor, uncond: torch.Tensor) -> None:
        super().__init__()
        self.cond, self.uncond = cond.log_softmax(-1), uncond.log_softmax(-1)
        self.calls = []

    def forward(self, x_t, t, text, text_padding_mask=None, *, padding_mask=None, drop_text=None, **_):
        self.calls.append(x_t.clone())
        B, L = x_t.shape
        out = self.cond.expand(B, L, -1).clone()
        if drop_text is not None:
            out[drop_text] = self.uncond
        return out


def _entropy(log_p: torch.Tensor) -> float:
    return float(-(log_p.exp() * log_p).sum())


def test_x0_entropy_equals_the_closed_form_for_a_fixed_denoiser_and_guidance_sharpens():
    g = torch.Generator().manual_seed(0)
    cond = torch.tensor([2.0, 1.0, 0.5, 0.0, 0.0, -1.0])
    uncond = torch.tensor([1.0, 1.0, 1.0, 0.2, 0.2, 0.2])  # flatter: close to a marginal
    model = FixedDenoiser(cond, uncond)
    tr = build_transitions(get_schedule(T=T), num_codes=K)
    text = torch.zeros(3, 2, 4)
    kw = dict(timesteps=[1, T], generator=g)

    plain = x0_entropy(model, tr, ROWS, text, **kw)
    log_c = cond.log_softmax(-1).double()
    codes = ROWS[ROWS >= 0]
    assert plain.entropy.tolist() == pytest.approx([_entropy(log_c)] * 2)
    assert plain.nll.tolist() == pytest.approx([float(-log_c[codes].mean())] * 2)
    assert plain.at(T) == pytest.approx((_entropy(log_c), float(-log_c[codes].mean())))
    with pytest.raises(ValueError):
        plain.at(2)  # a step the curve was not measured at

    s = 4.0
    guided = x0_entropy(model, tr, ROWS, text, guidance_scale=s, **kw)
    log_s = classifier_free_guidance(cond.log_softmax(-1), uncond.log_softmax(-1), s).double()
    assert guided.entropy.tolist() == pytest.approx([_entropy(log_s)] * 2, rel=1e-5)
    assert guided.entropy[0] < plain.entropy[0]  # sharpening

    null = x0_entropy(model, tr, ROWS, text, condition="null", **kw)
    assert null.entropy.tolist() == pytest.approx([_entropy(uncond.log_softmax(-1).double())] * 2)
    with pytest.raises(ValueError, match="guidance_scale"):
        x0_entropy(model, tr, ROWS, text, condition="null", guidance_scale=1.0, **kw)
    with pytest.raises(ValueError, match="condition"):
        x0_entropy(model, tr, ROWS, text, condition="none", **kw)
    with pytest.raises(ValueError, match="timesteps"):
        x0_entropy(model, tr, ROWS, text, timesteps=[0], generator=g)
    with pytest.raises(ValueError, match="text"):
        x0_entropy(model, tr, ROWS, text[:2], **kw)


def test_x0_entropy_corrupts_with_q_and_keeps_padding_masked():
    model = FixedDenoiser(torch.zeros(K), torch.zeros(K))
    tr = build_transitions(get_schedule(T=T), num_codes=K)
    x0_entropy(model, tr, ROWS, torch.zeros(3, 2, 4), timesteps=[1, T], generator=torch.Generator().manual_seed(0))
    first, last = model.calls
    pad = ROWS < 0
    assert (first[pad] == K).all() and (last[pad] == K).all()
    # At t = 1 almost every real token is still its code; at t = T most are masked (γ̄_T = 0.9).
    assert (first[~pad] == ROWS[~pad]).float().mean() > 0.7
    assert (last[~pad] == K).float().mean() > 0.5


# ------------------------------------------------------------------------------------ forward processes


def _codebook(seed: int = 0) -> torch.Tensor:
    return torch.randn(K, 3, generator=torch.Generator().manual_seed(seed))


def test_forward_tv_matches_a_row_by_row_loop_and_the_float64_version():
    schedule = get_schedule(T=T)
    uniform = build_transitions(schedule, num_codes=K)
    dynamic = build_transitions(schedule, codebook=_codebook(), eta=3.0)
    tv = forward_tv(dynamic, uniform)
    for t in (0, 3, T):
        a, b = dynamic.cumulative[t].double(), uniform.cumulative[t].double()
        by_hand = max(0.5 * float((a[i] - b[i]).abs().sum()) for i in range(K))
        assert float(tv[t]) == pytest.approx(by_hand, abs=1e-9)
    exact = dynamic_uniform_tv(schedule, _codebook(), [0.0, 3.0])
    assert float(exact[0].abs().max()) == 0.0  # η = 0 is the uniform process exactly
    np.testing.assert_allclose(exact[1].numpy(), tv.numpy(), atol=1e-6)
    # Only the replaced mass can move: TV <= K·β̄_t at every step.
    assert (exact[1] <= schedule.kbeta_bar + 1e-12).all() and float(exact[1, T]) > 0

    freq = torch.tensor([3.0, 1.0, 0.0, 0.0, 0.0, 0.0])
    mean = forward_tv(dynamic, uniform, reduce="mean", weights=freq)
    rows = 0.5 * (dynamic.cumulative[T, :2].double() - uniform.cumulative[T, :2].double()).abs().sum(-1)
    assert float(mean[T]) == pytest.approx(float(0.75 * rows[0] + 0.25 * rows[1]), abs=1e-9)
    with pytest.raises(ValueError, match="reduce"):
        forward_tv(dynamic, uniform, reduce="median")
    with pytest.raises(ValueError, match="weights"):
        forward_tv(dynamic, uniform, reduce="mean", weights=torch.ones(K + 1))
    with pytest.raises(ValueError, match="differ"):
        forward_tv(dynamic, build_transitions(get_schedule(T=T), num_codes=K + 1))


def test_dynamic_uniform_tv_grows_with_eta_and_with_t():
    tv = dynamic_uniform_tv(get_schedule(T=T), _codebook(), [0.25, 1.0, 4.0, 16.0])
    at_T = tv[:, T]
    assert (at_T[1:] > at_T[:-1]).all()
    assert (tv[:, 1:] >= tv[:, :-1] - 1e-12).all()  # the difference accumulates over the steps
    with pytest.raises(ValueError, match="etas"):
        dynamic_uniform_tv(get_schedule(T=T), _codebook(), [])


# ------------------------------------------------------------------------------------------ renderers


def test_token_statistics_are_the_histogram_tv_and_the_repeat_rate():
    real = [torch.tensor([0, 1, 2, 3]), torch.tensor([4, 5])]
    stats = token_statistics(ROWS, real, K)
    assert stats == {"hist_tv": histogram_tv(ROWS, real, K), "repeat_rate": adjacent_repeat_rate(ROWS)}
    assert token_statistics(real, real, K)["hist_tv"] == 0.0


def test_markdown_table_renders_header_rule_and_cells():
    table = MarkdownTable.of(["", "a", "b"], [["row", Estimate(1.0, 0.5, 3), "–"]])
    assert str(table).splitlines() == ["|  | a | b |", "|---|---:|---:|", "| row | 1.00 ± 0.50 | – |"]
    assert table._repr_markdown_() == str(table)
    # a "|" inside a cell is escaped: each line keeps its three columns (e.g. "p(x0 | x_t)")
    piped = MarkdownTable.of(["", "p(a | b)"], [["x | y", 1]])
    assert [line.replace(r"\|", "").count("|") for line in str(piped).splitlines()] == [3, 3, 3]


def test_eta_distances_hold_the_tv_the_cap_and_the_table():
    schedule, etas = get_schedule(T=T), [0.5, 4.0, 64.0]
    weights = torch.tensor([3.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    distances = eta_distances(schedule, _codebook(), etas, weights=weights)
    np.testing.assert_array_equal(distances.largest.numpy(), dynamic_uniform_tv(schedule, _codebook(), etas).numpy())
    mean = dynamic_uniform_tv(schedule, _codebook(), etas, reduce="mean", weights=weights)
    np.testing.assert_array_equal(distances.mean.numpy(), mean.numpy())
    assert distances.at(0.0) == 0.0 and distances.at(4.0) == float(distances.largest[1].max())
    assert distances.cap_T == pytest.approx(float(schedule.kbeta_bar[-1]))
    half = [e for e in etas if distances.at(e) >= 0.5 * distances.cap_T]
    assert distances.half_cap() == (half[0] if half else None)
    lines = distances.to_markdown().splitlines()
    assert len(lines) == 2 + len(etas) and lines[3].startswith(f"| 4 | {distances.at(4.0):.4f} | ")
    swept = distances.with_column("FID", {0.0: Estimate(2.0, 0.5, 3), 4.0: 1.5})
    lines = swept.to_markdown().splitlines()
    assert lines[0].endswith("| FID |") and lines[2] == "| 0 | 0.0000 | 0.0 % | 2.00 ± 0.50 |" and len(lines) == 4
    sentence = distances.describe(0.5, others=(4.0,))
    assert f"moves at most {distances.at(0.5):.4f}" in sentence and f"η = 4: {distances.at(4.0):.4f}" in sentence
    with pytest.raises(KeyError, match="not measured"):
        distances.at(2.0)
    with pytest.raises(ValueError, match="positive"):
        eta_distances(schedule, _codebook(), [0.0, 1.0])
