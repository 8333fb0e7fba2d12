"""The conv encoder/decoder: shapes, ×4 temporal downsampling, dilation order."""

import pytest
import torch

from motionlab.tokenizers import Decoder, Encoder, Resnet1D


@pytest.mark.parametrize("frames", [4, 64, 196])
def test_encoder_downsamples_by_four_and_decoder_restores(frames):
    enc, dec = Encoder(263, 16, width=24, depth=2), Decoder(263, 16, width=24, depth=2)
    x = torch.randn(2, frames, 263)
    z = enc(x)
    assert z.shape == (2, frames // 4, 16)
    assert dec(z).shape == (2, frames, 263)


def test_strided_convs_and_upsampling_layout():
    enc, dec = Encoder(10, 8, width=12, depth=1), Decoder(10, 8, width=12, depth=1)
    strided = [m for m in enc.modules() if isinstance(m, torch.nn.Conv1d) and m.stride == (2,)]
    assert [(m.kernel_size, m.padding) for m in strided] == [((4,), (1,))] * 2
    ups = [m for m in dec.modules() if isinstance(m, torch.nn.Upsample)]
    assert len(ups) == 2 and all(m.scale_factor == 2 and m.mode == "nearest" for m in ups)


def test_resnet_dilations_are_reversed_powers_and_keep_length():
    net = Resnet1D(width=6, depth=3, dilation_growth=3)
    assert [block.conv1.dilation[0] for block in net] == [9, 3, 1]
    x = torch.randn(1, 6, 20)
    assert net(x).shape == x.shape
    # pre-activation residual: a block whose convs output zero is the identity
    for block in net:
        torch.nn.init.zeros_(block.conv2.weight)
        torch.nn.init.zeros_(block.conv2.bias)
    assert torch.equal(net(x), x)
