"""VQVAE / RVQVAE through the Tokenizer interface; configs; the loss; bad inputs."""

import pytest
import torch

from motionlab.tokenizers import (
    RVQVAE,
    VQVAE,
    RVQConfig,
    Tokenizer,
    VQConfig,
    build_tokenizer,
    ric_slice,
    rvq_config,
    tokenizer_loss,
    vq_config,
)
from motionlab.train import load_weights, save_checkpoint


@pytest.fixture(params=["vq", "rvq"])
def model(request):
    config = vq_config("smoke") if request.param == "vq" else rvq_config("smoke")
    return build_tokenizer(config).eval()


def test_interface_round_trip(model, smooth_motion):
    assert isinstance(model, Tokenizer)
    assert (model.downsample, model.feature_dim, model.code_dim) == (4, 263, 16)
    x = smooth_motion(2, 24)
    ids = model.encode(x)
    expected = (2, 6) if model.num_layers == 1 else (2, 6, model.num_layers)
    assert ids.shape == expected and ids.dtype == torch.long
    z = model.embed(ids)
    assert z.shape == (2, 6, model.code_dim)
    recon = model.decode(ids)
    assert recon.shape == x.shape
    out = model(x)  # eval forward: the same argmin codes
    assert torch.equal(out.ids, ids)
    assert torch.allclose(out.recon, recon, atol=1e-5)
    assert torch.allclose(model.decode_latent(z), recon)
    assert model.codebook().shape == (model.codebook_size, model.code_dim)
    if model.num_layers == 1:
        assert torch.equal(z, model.codebook()[ids])
    else:
        manual = sum(model.codebook(k)[ids[..., k]] for k in range(model.num_layers))
        assert torch.allclose(z, manual, atol=1e-6)


def test_encode_never_changes_state(model, smooth_motion):
    model.train()
    before = {k: v.clone() for k, v in model.state_dict().items()}
    a = model.encode(smooth_motion(2, 16))
    b = model.encode(smooth_motion(2, 16))
    assert torch.equal(a, b)
    for k, v in model.state_dict().items():
        assert torch.equal(v, before[k]), k


def test_rvq_fewer_layers(smooth_motion):
    model = build_tokenizer(rvq_config("smoke")).eval()
    x = smooth_motion(1, 16)
    ids = model.encode(x)  # (1, 4, 3)
    assert torch.allclose(model.embed(ids, num_layers=2), model.embed(ids[..., :2]))
    assert model.decode(ids[..., :1]).shape == x.shape
    partial = model.encode(x, num_layers=2)
    assert torch.equal(partial[..., :2], ids[..., :2]) and torch.all(partial[..., 2] == -1)
    codes = model.get_codes_from_indices(partial)
    assert codes.shape == (3, 1, 4, 16) and torch.all(codes[2] == 0)
    with pytest.raises(ValueError, match="num_layers"):
        model.embed(ids, num_layers=4)
    with pytest.raises(ValueError, match="num_layers"):
        model.encode(x, num_layers=0)


def test_bad_inputs(model, smooth_motion):
    with pytest.raises(ValueError, match="multiple of 4"):
        model.encode(smooth_motion(1, 10))
    with pytest.raises(ValueError, match=r"\(B, T, 263\)"):
        model.encode(torch.randn(1, 16, 251))
    with pytest.raises(ValueError, match=r"\(B, T, 263\)"):
        model.encode(torch.randn(16, 263))
    good = model.encode(smooth_motion(1, 16))
    with pytest.raises(ValueError, match=r"\[.*32\)"):
        model.decode(torch.full_like(good, 32))
    with pytest.raises(ValueError, match="integer"):
        model.decode(good.float())
    with pytest.raises(ValueError, match="layer"):
        model.codebook(model.num_layers)
    if model.num_layers == 1:
        with pytest.raises(ValueError, match=r"\[0, 32\)"):
            model.decode(torch.full_like(good, -1))
        with pytest.raises(ValueError, match=r"\(B, N\)"):
            model.decode(good[..., None])
    else:
        with pytest.raises(ValueError, match="R"):
            model.decode(torch.cat([good, good], dim=-1))


def test_boundaries_convert_float64_and_reject_nan_and_empty_ids(model, smooth_motion):
    import numpy as np

    x = smooth_motion(1, 16)
    ids = model.encode(x)
    assert torch.equal(model.encode(x.double()), ids)  # float64 is converted at the boundary
    assert torch.equal(model.encode(x.double().numpy()), ids)
    assert torch.equal(model.encode(np.asarray(x, dtype=np.float64)), ids)
    for bad in (float("nan"), float("inf")):
        y = x.clone()
        y[0, 3, 7] = bad
        with pytest.raises(ValueError, match="motion contains NaN or inf"):
            model.encode(y)
        with pytest.raises(ValueError, match="NaN or inf"):
            model(y)
    with pytest.raises(ValueError, match="ids must hold at least one token"):
        model.decode(ids[:, :0])
    with pytest.raises(ValueError, match="ids must hold at least one token"):
        model.embed(ids[:0])


def test_checkpoint_config_mismatch(tmp_path):
    small = build_tokenizer(vq_config("smoke"))
    path = save_checkpoint(tmp_path, 0, small)
    other = build_tokenizer(vq_config("smoke", codebook_size=64))
    with pytest.raises(ValueError, match="config mismatch"):
        load_weights(other, path / "model.safetensors")
    with pytest.raises(ValueError, match="VQConfig or RVQConfig"):
        build_tokenizer(object())


def test_same_config_same_weights():
    a, b = build_tokenizer(rvq_config("smoke")), build_tokenizer(rvq_config("smoke"))
    for (k, v), w in zip(a.state_dict().items(), b.state_dict().values()):
        assert torch.equal(v, w), k
    c = build_tokenizer(rvq_config("smoke", seed=1))
    assert not torch.equal(a.encoder.net[0].weight, c.encoder.net[0].weight)


def test_profile_configs():
    full_vq, full_rvq = vq_config("full"), rvq_config("full")
    assert (full_vq.codebook_size, full_vq.code_dim, full_vq.width, full_vq.depth) == (512, 512, 512, 3)
    assert (full_vq.dilation_growth, full_vq.window, full_vq.batch_size) == (3, 64, 256)
    assert full_vq.train.lr == 2e-4 and full_vq.train.betas == (0.9, 0.99) and full_vq.train.warmup_steps == 1000
    assert full_vq.train.milestones == (200_000,) and full_vq.train.gamma == 0.05
    assert (full_rvq.num_layers, full_rvq.quantize_dropout, full_rvq.gumbel_temperature) == (6, 0.2, 0.5)
    assert full_rvq.train.milestones == (150_000, 250_000) and full_rvq.train.warmup_steps == 2000
    assert isinstance(full_rvq, RVQConfig) and type(full_vq) is VQConfig
    for profile in ("smoke", "laptop"):
        assert vq_config(profile).width < full_vq.width and rvq_config(profile).train.steps < 10_000
    assert vq_config("smoke", codebook_size=7).codebook_size == 7
    with pytest.raises(ValueError, match="unknown VQConfig"):
        vq_config("smoke", codebooks=7)
    with pytest.raises(ValueError, match="multiple of 4"):
        VQConfig(window=30)
    with pytest.raises(ValueError, match="profile"):
        rvq_config("huge")


def test_loss_terms():
    target = torch.randn(2, 8, 263, generator=torch.Generator().manual_seed(0))
    zero = tokenizer_loss(target.clone(), target, torch.tensor(0.0))
    assert all(v.item() == 0 for v in zero.values())
    assert ric_slice(22) == slice(4, 67) and ric_slice(21) == slice(4, 64)

    off_ric = target.clone()
    off_ric[..., 100] += 1.0  # a rotation dim: recon changes, ric does not
    terms = tokenizer_loss(off_ric, target, torch.tensor(0.0))
    assert terms["ric"].item() == 0 and terms["recon"].item() == pytest.approx(0.5 / 263)

    on_ric = target.clone()
    on_ric[..., 10] += 1.0  # smooth L1 of an error of 1 is 0.5
    terms = tokenizer_loss(on_ric, target, torch.tensor(2.0))
    assert terms["recon"].item() == pytest.approx(0.5 / 263)
    assert terms["ric"].item() == pytest.approx(0.5 / 63)
    assert terms["loss"].item() == pytest.approx(0.5 / 263 + 0.5 * 0.5 / 63 + 0.02 * 2.0)
    with pytest.raises(ValueError, match="must match"):
        tokenizer_loss(target[:, :4], target, torch.tensor(0.0))
    with pytest.raises(ValueError, match="n_joints"):
        tokenizer_loss(target[..., :20], target[..., :20], torch.tensor(0.0))


def test_classes():
    assert type(build_tokenizer(vq_config("smoke"))) is VQVAE
    assert type(build_tokenizer(rvq_config("smoke"))) is RVQVAE
