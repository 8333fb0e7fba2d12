"""Baselines: SLERP generation lengths, handshake windows and the averaging at shared tokens."""

from __future__ import annotations

import pytest
import torch
from torch import nn

from motionlab.multimotion import (
    SegmentLayout,
    handshake_sample,
    handshake_windows,
    independent_sample,
    shortened_lengths,
    two_phase_sample,
)

K, T = 12, 10  # as in conftest.py


class TextPicker(nn.Module):
    """A stand-in denoiser: p(x_0) at every position is softmax(50 · the segment's first text token)."""

    def forward(self, x_t, t, text, text_padding_mask=None, **kw):
        log_p = torch.log_softmax(50.0 * text[:, :1, :K], dim=-1)  # (B, 1, K)
        return log_p.expand(x_t.shape[0], x_t.shape[1], K)


def one_hot_texts(codes: list[int]) -> torch.Tensor:
    return torch.eye(K)[codes][:, None, :]  # (M, 1, K): segment m "asks for" code codes[m]


def test_shortened_lengths():
    assert shortened_lengths([100, 80, 60]) == [80, 40, 40]
    assert shortened_lengths([100]) == [100]
    assert shortened_lengths([40, 40], transition=8) == [36, 36]
    with pytest.raises(ValueError, match="too short"):
        shortened_lengths([40, 40, 40])  # the middle one would keep 0 frames
    with pytest.raises(ValueError, match="multiple of 8"):
        shortened_lengths([100, 100], transition=36)


def test_handshake_windows_share_the_transition_around_each_boundary():
    layout = SegmentLayout.from_frames([[40, 40, 40], [80], [8, 60]])
    windows = handshake_windows(layout, transition=16)  # 2 tokens into each neighbour
    assert windows == [(0, 0, 12), (0, 8, 22), (0, 18, 30), (1, 0, 20), (2, 0, 4), (2, 0, 17)]
    for (b0, _, stop), (b1, start, _), bound in [(windows[0], windows[1], 40), (windows[1], windows[2], 80)]:
        assert b0 == b1 == 0 and stop - start == 4  # 16 frames shared ...
        assert (start + stop) * 4 // 2 == bound  # ... centred on the boundary frame
    windows40 = handshake_windows(SegmentLayout.from_frames([100, 100]), transition=40)
    assert windows40 == [(0, 0, 30), (0, 20, 50)]  # 10 shared tokens = 40 frames, boundary at frame 100


def test_handshake_averages_the_predictions_of_overlapping_windows(tiny):
    _, tr = tiny
    out = handshake_sample(
        TextPicker(),
        tr,
        (one_hot_texts([0, 1, 2]), None),
        [40, 40, 40],
        transition=16,
        generator=torch.Generator().manual_seed(0),
    )
    seq = out.concatenated()[0]
    assert seq[:8].tolist() == [0] * 8 and seq[12:18].tolist() == [1] * 6 and seq[22:].tolist() == [2] * 8
    shared = [seq[8:12]]
    for seed in range(1, 6):
        again = handshake_sample(
            TextPicker(),
            tr,
            (one_hot_texts([0, 1, 2]), None),
            [40, 40, 40],
            transition=16,
            generator=torch.Generator().manual_seed(seed),
        ).concatenated()[0]
        shared.append(again[8:12])
        assert set(again[18:22].tolist()) <= {1, 2}
    values = torch.cat(shared)
    assert set(values.tolist()) == {0, 1}  # a 50/50 mixture of the two windows' predictions
    assert 0.25 < (values == 0).float().mean() < 0.75
    assert [len(s) for s in out.segments()] == [10, 10, 10]


def test_handshake_keeps_the_requested_layout(tiny):
    model, tr = tiny
    text = torch.randn(3, 4, 8, generator=torch.Generator().manual_seed(2))
    out = handshake_sample(
        model,
        tr,
        (text, None),
        [[40, 48], [24]],
        transition=16,
        num_steps=5,
        guidance_scale=1.5,
        top_p=0.9,
        generator=torch.Generator().manual_seed(0),
    )
    assert [len(s) for s in out.segments(0)] == [10, 12] and [len(s) for s in out.segments(1)] == [6]
    assert ((out.ids == -1) | ((out.ids >= 0) & (out.ids < K))).all() and (out.ids[2, 6:] == -1).all()
    assert out.boundaries(0) == [40]


def test_handshake_guides_the_posterior_where_asked(tiny):
    model, tr = tiny
    text = torch.randn(2, 4, 8, generator=torch.Generator().manual_seed(2))

    def draw(**sampling):
        kw = dict(transition=16, num_steps=5, generator=torch.Generator().manual_seed(0))
        return handshake_sample(model, tr, (text, None), [[40, 48]], **kw, **sampling).ids

    # without guidance there is nothing to place: both spaces draw the same tokens
    assert torch.equal(draw(guidance_scale=0.0), draw(guidance_scale=0.0, guidance_on="posterior"))
    assert not torch.equal(draw(guidance_scale=3.0), draw(guidance_scale=3.0, guidance_on="posterior"))
    with pytest.raises(ValueError, match="guidance_on"):
        draw(guidance_scale=3.0, guidance_on="x_t")


def test_independent_baseline_is_tps_without_joint_steps(tiny):
    model, tr = tiny
    text = torch.randn(3, 4, 8, generator=torch.Generator().manual_seed(2))
    a = independent_sample(model, tr, (text, None), [16, 24, 8], generator=torch.Generator().manual_seed(1))
    b = two_phase_sample(model, tr, (text, None), [16, 24, 8], T_s=T, generator=torch.Generator().manual_seed(1))
    assert torch.equal(a.ids, b.ids)
