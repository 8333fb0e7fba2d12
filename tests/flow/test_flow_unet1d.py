"""The 1D U-Net vector field: shapes, length generality, input checks."""

from __future__ import annotations

import pytest
import torch

from motionlab.flow.unet1d import SinusoidalTimeEmbedding, UNet1D, UNetConfig

D, C = 7, 5
TINY = UNetConfig(feature_dim=D, cond_dim=C, width=8, width_mults=(1, 2))


def net(config: UNetConfig = TINY) -> UNet1D:
    torch.manual_seed(0)  # parameter init only
    return UNet1D(config).eval()


def inputs(T: int, B: int = 2, seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    return torch.randn(B, T, D, generator=g), torch.rand(B, generator=g), torch.randn(B, T, C, generator=g)


def test_dims_follow_the_paper_layout():
    assert UNetConfig().dims == [512, 512, 1024]
    assert UNetConfig().time_dim == 2048


@pytest.mark.parametrize("T", [64, 196, 200, 4])
def test_runs_on_any_length_multiple_of_4(T):
    x, t, c = inputs(T)
    with torch.no_grad():
        assert net()(x, t, c).shape == (2, T, D)


@pytest.mark.parametrize("mults", [(1,), (1, 2, 2)])
def test_other_depths(mults):
    cfg = UNetConfig(feature_dim=D, cond_dim=C, width=8, width_mults=mults, resnets_per_level=2)
    x, t, c = inputs(64)
    with torch.no_grad():
        assert net(cfg)(x, t, c).shape == (2, 64, D)


def test_output_depends_on_time_and_condition():
    model = net()
    x, t, c = inputs(64)
    with torch.no_grad():
        base = model(x, t, c)
        assert not torch.allclose(base, model(x, 1 - t, c))
        assert not torch.allclose(base, model(x, t, c + 1))


def test_batch_items_are_independent():
    model = net()
    x, t, c = inputs(64, B=3)
    with torch.no_grad():
        full = model(x, t, c)
        one = model(x[1:2], t[1:2], c[1:2])
    torch.testing.assert_close(full[1:2], one, atol=1e-5, rtol=1e-5)


def test_time_embedding_uses_t_as_is():
    emb = SinusoidalTimeEmbedding(8)
    out = emb(torch.tensor([0.0, 0.5]))
    torch.testing.assert_close(out[0], torch.tensor([0.0] * 4 + [1.0] * 4))
    assert out[1, 0] == pytest.approx(torch.sin(torch.tensor(0.5)).item())  # ω_0 = 1, no ×1000 scaling


def test_rejects_bad_inputs():
    model = net()
    x, t, c = inputs(64)
    with pytest.raises(ValueError, match="multiple of 4"):
        model(*inputs(198))
    with pytest.raises(ValueError, match=r"x must have shape \(B, T, 7\)"):
        model(torch.zeros(2, 64, D + 1), t, c)
    with pytest.raises(ValueError, match=r"t must have shape \(2,\)"):
        model(x, torch.zeros(2, 1), c)
    with pytest.raises(ValueError, match=r"cond must have shape \(2, 64, 5\)"):
        model(x, t, c[:, :60])
    with pytest.raises(ValueError, match="width_mults"):
        UNetConfig(width_mults=())
    with pytest.raises(ValueError, match="length_multiple"):
        UNetConfig(width_mults=(1, 2, 2, 2), length_multiple=4)  # three halvings need a multiple of 8
