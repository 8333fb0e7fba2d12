"""T2M-GPT's VQ-VAE (``net_last.pth`` + meta) → motionlab's VQVAE, sizes read off the state dict."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from released_layouts import (
    VQSize,
    official_decode,
    official_encode,
    official_quantize,
    random_state,
    t2mgpt_manifest,
    write_t2mgpt,
)

from motionlab.pretrained import UnsupportedSettingError, load, load_t2mgpt_vq, t2mgpt_vq_keymap
from motionlab.tokenizers import VQVAE

ATOL = 2e-6


@pytest.mark.parametrize("features", [263, 251])
def test_loads_and_matches_the_official_forward(tmp_path, features):
    s = VQSize(features=features, depth=3, width=24, quantizers=1)
    released = write_t2mgpt(tmp_path / "t2m", s)
    model = load_t2mgpt_vq(released.checkpoint, released.extra["meta"])
    assert isinstance(model, VQVAE) and not model.training
    c = model.config
    assert (c.feature_dim, c.width, c.depth, c.code_dim, c.codebook_size) == (features, 24, 3, 16, 8)
    assert c.n_joints == (22 if features == 263 else 21) and c.dropout == 0.0
    x = torch.randn(2, 24, features, generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        z = official_encode(released.state, x, s, prefix="vqvae.")
        ids, codes = official_quantize([released.state["vqvae.quantizer.codebook"]], z)
        ours = model.encode(x)
        assert torch.equal(ours, ids[..., 0])
        assert torch.allclose(model.decode(ours), official_decode(released.state, codes, s, prefix="vqvae."), atol=ATOL)
    info = model.provenance
    assert info.kind == "t2mgpt_vq" and info.config["dilation_growth_rate"] == 3 and info.epoch is None
    assert np.allclose(model.normalizer.std, np.load(released.extra["meta"] / "std.npy"))


def test_folder_path_meta_spellings_and_best_fid(tmp_path):
    released = write_t2mgpt(tmp_path / "t2m", name="net_best_fid.pth")
    meta = released.extra["meta"]
    for name in ("mean", "std"):
        (meta / f"{name}.npy").rename(meta / f"{name.capitalize()}.npy")  # HumanML3D's Mean.npy / Std.npy
    model = load_t2mgpt_vq(released.folder, meta)
    assert model.provenance.files[0].endswith("net_best_fid.pth")
    with pytest.raises(FileNotFoundError, match="mean.npy and std.npy"):
        load_t2mgpt_vq(released.folder, tmp_path)


def test_load_finds_meta_beside_the_checkpoint(tmp_path):
    released = write_t2mgpt(tmp_path / "t2m")
    (released.extra["meta"]).rename(released.folder / "meta")
    assert isinstance(load(released.checkpoint), VQVAE)


def test_three_stages_refused(tmp_path):
    s = VQSize(stages=3, quantizers=1)
    released = write_t2mgpt(tmp_path / "t2m", s)
    with pytest.raises(UnsupportedSettingError, match="down_t=3"):
        load_t2mgpt_vq(released.checkpoint, released.extra["meta"])


def test_keymap_is_invertible():
    state = random_state(t2mgpt_manifest(VQSize(depth=3, quantizers=1)))
    keymap = t2mgpt_vq_keymap(3)
    back = keymap.to_official(keymap.to_motionlab(state))
    assert back.keys() == state.keys() and all(torch.equal(back[k], state[k]) for k in state)
