"""MoMask's residual VQ-VAE in its released layouts → motionlab's RVQVAE, checked against an independent forward."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from released_layouts import (
    VQSize,
    momask_manifest,
    official_codes,
    official_decode,
    official_encode,
    official_quantize,
    random_state,
    write_momask,
)

from motionlab.pretrained import UnsupportedSettingError, load_momask_rvq, momask_rvq_keymap
from motionlab.pretrained.files import read_opt_txt
from motionlab.tokenizers import RVQVAE

ATOL = 2e-6


def _codebooks(state, s: VQSize):
    return [state[f"quantizer.layers.{k}.codebook"] for k in range(s.quantizers)]


@pytest.mark.parametrize(("dataset", "features"), [("t2m", 263), ("kit", 251)])
def test_loads_and_matches_the_official_forward(tmp_path, dataset, features):
    s = VQSize(features=features)
    released = write_momask(tmp_path / "rvq", s, dataset=dataset)
    model = load_momask_rvq(released.folder)
    assert isinstance(model, RVQVAE) and not model.training
    assert (model.feature_dim, model.num_layers, model.codebook_size, model.code_dim) == (features, 2, 8, 16)
    assert model.config.n_joints == (22 if dataset == "t2m" else 21)

    x = torch.randn(3, 32, features, generator=torch.Generator().manual_seed(5))
    with torch.no_grad():
        z = official_encode(released.state, x, s)  # (B, C, N)
        ids, codes = official_quantize(_codebooks(released.state, s), z)
        ours = model.encode(x)
        assert torch.equal(ours, ids)
        assert torch.allclose(model.embed(ours), codes.transpose(1, 2), atol=ATOL)
        assert torch.allclose(model.decode(ours), official_decode(released.state, codes, s), atol=ATOL)
        # fewer layers (MoMask pads the rest with −1): only the first layer's codes
        first = ours[..., :1]
        want = official_decode(released.state, official_codes(_codebooks(released.state, s), first), s)
        assert torch.allclose(model.decode(first), want, atol=ATOL)


def test_normalizer_and_provenance(tmp_path):
    released = write_momask(tmp_path / "rvq")
    model = load_momask_rvq(released.folder)
    mean = np.load(released.folder / "meta" / "mean.npy")
    assert np.allclose(model.normalizer.mean, mean) and model.normalizer.dim == 263
    info = model.provenance
    assert (info.kind, info.layout, info.epoch, info.iteration) == ("momask_rvq", "momask", 7, 1234)
    assert info.config["num_quantizers"] == 2 and info.config["vq_norm"] == "None"
    assert any(f.endswith("net_best_fid.tar") for f in info.files)
    with pytest.raises(TypeError):
        info.config["width"] = 1  # read-only


def test_discord_copy_of_the_tokenizer_loads_the_same(tmp_path):
    state = random_state(momask_manifest(VQSize()), seed=3)
    a = load_momask_rvq(write_momask(tmp_path / "a", state=state).folder)
    b = load_momask_rvq(write_momask(tmp_path / "Momask", state=state, layout="discord").folder)
    assert b.provenance.layout == "discord-momask"
    for key, value in a.state_dict().items():
        assert torch.equal(value, b.state_dict()[key]), key


def test_other_checkpoint_name_and_device(tmp_path):
    released = write_momask(tmp_path / "rvq")
    released.checkpoint.rename(released.folder / "model" / "latest.tar")
    with pytest.raises(FileNotFoundError, match="model/net_best_fid.tar"):
        load_momask_rvq(released.folder)
    model = load_momask_rvq(released.folder, device="cpu", checkpoint="latest.tar")
    assert model.device.type == "cpu"


def test_opt_txt_is_parsed_like_get_opt(tmp_path):
    write_momask(tmp_path / "rvq", lr=0.0002, weight_decay=1e-05, gpu_id=-1)
    opt = read_opt_txt(tmp_path / "rvq" / "opt.txt")
    assert opt["is_continue"] is False and opt["shared_codebook"] is False
    assert opt["nb_code"] == 8 and isinstance(opt["nb_code"], int) and opt["gpu_id"] == -1
    assert opt["lr"] == 0.0002 and opt["mu"] == 0.99
    assert opt["vq_norm"] == "None" and opt["milestones"] == "[150000, 250000]"
    assert opt["weight_decay"] == "1e-05"  # get_opt's float pattern needs a decimal point


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"down_t": 3}, "down_t=3"),
        ({"stride_t": 3}, "stride_t=3"),
        ({"vq_act": "silu"}, "vq_act='silu'"),
        ({"vq_norm": "LN"}, "vq_norm='LN'"),
        ({"shared_codebook": True}, "shared_codebook=True"),
        ({"output_emb_width": 32}, "output_emb_width=32"),
        ({"dataset_name": "humanml3d"}, "dataset_name='humanml3d'"),
    ],
)
def test_unsupported_settings_are_refused_by_name(tmp_path, change, named):
    released = write_momask(tmp_path / "rvq", **change)
    with pytest.raises(UnsupportedSettingError) as err:
        load_momask_rvq(released.folder)
    assert named in str(err.value) and "opt.txt" in str(err.value)


def test_missing_files_are_all_named(tmp_path):
    released = write_momask(tmp_path / "rvq")
    (released.folder / "meta" / "std.npy").unlink()
    released.checkpoint.unlink()
    with pytest.raises(FileNotFoundError) as err:
        load_momask_rvq(released.folder)
    assert "model/net_best_fid.tar" in str(err.value) and "meta/std.npy" in str(err.value)
    with pytest.raises(FileNotFoundError, match="opt.txt"):
        load_momask_rvq(tmp_path / "empty")


def test_keymap_is_invertible():
    s = VQSize(depth=3, quantizers=3)
    state = random_state(momask_manifest(s))
    keymap = momask_rvq_keymap(depth=3, num_quantizers=3)
    assert set(keymap.names) == set(state)
    back = keymap.to_official(keymap.to_motionlab(state))
    assert back.keys() == state.keys() and all(torch.equal(back[k], state[k]) for k in state)
