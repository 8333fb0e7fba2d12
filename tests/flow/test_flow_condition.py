"""Condition projection: token code vectors (B, N, d) -> frame features (B, q·N, c)."""

from __future__ import annotations

import pytest
import torch

from motionlab.flow.condition import (
    CONDITION_PROJECTIONS,
    StackedProjection,
    frames_per_token_distinct,
    make_condition_projection,
)

B, N, D_CODE, C, Q = 2, 5, 8, 6, 4


def codes(seed: int = 0) -> torch.Tensor:
    return torch.randn(B, N, D_CODE, generator=torch.Generator().manual_seed(seed))


def build(kind: str, q: int = Q):
    torch.manual_seed(0)  # parameter init only
    return make_condition_projection(kind, D_CODE, C, q=q)


@pytest.mark.parametrize("kind", CONDITION_PROJECTIONS)
@pytest.mark.parametrize("q", [2, 3, 4])
def test_every_projection_maps_tokens_to_frames(kind, q):
    out = build(kind, q)(codes())
    assert out.shape == (B, q * N, C)


def test_stacked_projection_gives_q_distinct_features_per_token_and_repeat_does_not():
    z = codes()
    stacked = build("stacked")(z)
    repeat = build("repeat")(z)
    assert frames_per_token_distinct(stacked, Q).all()
    assert not frames_per_token_distinct(repeat, Q).any()
    # naive repeat: the q frames of token n are literally the same vector
    grouped = repeat.reshape(B, N, Q, C)
    torch.testing.assert_close(grouped, grouped[:, :, :1].expand_as(grouped))


def test_stacked_projection_keeps_token_frame_correspondence():
    proj = build("stacked")
    z = codes()
    z2 = z.clone()
    z2[:, 2] += 1.0  # change token 2 only
    changed = (proj(z2) - proj(z)).abs().amax(dim=(0, 2)) > 1e-6  # (q·N,)
    expected = torch.zeros(Q * N, dtype=torch.bool)
    expected[2 * Q : 3 * Q] = True
    assert torch.equal(changed, expected)


def test_transposed_conv_mixes_neighbouring_tokens():
    proj = build("transposed")
    z = codes()
    z2 = z.clone()
    z2[:, 2] += 1.0
    changed = (proj(z2) - proj(z)).abs().amax(dim=(0, 2)) > 1e-6
    assert changed[2 * Q : 3 * Q].all()
    assert changed[: 2 * Q].any() or changed[3 * Q :].any()  # frames of tokens 1 or 3 move too


def test_stacked_projection_equals_one_linear_map_to_q_frames():
    # repeat → stack → W is W's q column blocks summed, applied to z: a linear d -> q·d map.
    proj = build("stacked")
    assert isinstance(proj, StackedProjection)
    z = codes()
    W, bias = proj.stacked.weight, proj.stacked.bias  # (q·d, q·d), (q·d,)
    W_sum = W.reshape(Q * D_CODE, Q, D_CODE).sum(dim=1)  # (q·d, d)
    frames = (z @ W_sum.T + bias).reshape(B, N * Q, D_CODE)
    torch.testing.assert_close(proj(z), proj.frame(frames))


def test_projection_rejects_bad_inputs():
    with pytest.raises(ValueError, match="kind"):
        make_condition_projection("bilinear", D_CODE, C)
    with pytest.raises(ValueError, match="cond_dim"):
        make_condition_projection("stacked", D_CODE, 0)
    with pytest.raises(ValueError, match="q"):
        make_condition_projection("stacked", D_CODE, C, q=0)
    proj = build("stacked")
    with pytest.raises(ValueError, match=r"\(B, N, 8\)"):
        proj(torch.zeros(B, N, D_CODE + 1))
    with pytest.raises(ValueError, match=r"\(B, N, 8\)"):
        proj(torch.zeros(N, D_CODE))
