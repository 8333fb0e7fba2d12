"""DisCoRD's rectified-flow decoder in its released layout → motionlab's DisCoRDDecoder attached to its tokenizer."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import yaml
from released_layouts import (
    UNetSize,
    VQSize,
    discord_manifest,
    discord_model_yaml,
    official_sample,
    official_unet,
    random_state,
    write_discord,
    write_momask,
)

from motionlab.flow import DisCoRDDecoder
from motionlab.pretrained import (
    CheckpointError,
    UnsupportedSettingError,
    discord_keymap,
    load_discord_decoder,
    load_momask_rvq,
)

ATOL = 1e-5  # the U-Net's outputs are O(1) here; float32 sums in another order


def _inputs(u: UNetSize, B: int = 2, T: int = 16, seed: int = 4):
    g = torch.Generator().manual_seed(seed)
    return (
        torch.randn(B, T, u.features, generator=g),
        torch.rand(B, generator=g),
        torch.randn(B, T // 4, u.c_in, generator=g),
    )


@pytest.mark.parametrize(
    "u",
    [
        UNetSize(),  # the released structure: dim_mults (1, 2), one ResNet per level, stacked projection
        UNetSize(mults=(1, 2, 2), per_block=2, up_conv_c="Repeat_and_linear"),
    ],
)
def test_velocity_matches_the_official_unet(tmp_path, u):
    released = write_discord(tmp_path / "DisCoRD", u)
    decoder = load_discord_decoder(released.folder)
    assert isinstance(decoder, DisCoRDDecoder) and not decoder.training
    x, t, y = _inputs(u)
    with torch.no_grad():
        assert torch.allclose(decoder.velocity(x, t, y), official_unet(released.state, x, t, y, u), atol=ATOL)


def test_decode_is_the_official_16_point_midpoint_solve(tmp_path):
    u = UNetSize()
    released = write_discord(tmp_path / "DisCoRD", u)
    decoder = load_discord_decoder(released.folder)
    c = decoder.config
    assert (c.prediction, c.normalization, c.time_distribution) == ("v", "std", "uniform")
    assert (c.sample_steps, c.solver, c.spacing, c.temperature) == (15, "midpoint", "uniform", 1.0)
    tokenizer = decoder.tokenizer
    ids = tokenizer.encode(torch.randn(2, 16, 263, generator=torch.Generator().manual_seed(2)))
    noise = torch.randn((2, 16, 263), generator=torch.Generator().manual_seed(9))
    with torch.no_grad():
        want = official_sample(released.state, tokenizer.embed(ids), u, noise)
        assert torch.allclose(decoder.decode(ids, seed=9), want, atol=5e-5)


def test_tokenizer_resolution_and_provenance(tmp_path):
    released = write_discord(tmp_path / "DisCoRD")
    decoder = load_discord_decoder(released.folder)
    tokenizer = decoder.tokenizer
    assert tokenizer.provenance.layout == "discord-momask"
    assert np.allclose(decoder.normalizer.mean, tokenizer.normalizer.mean)
    info = decoder.provenance
    assert info.kind == "discord_decoder" and info.config["model"]["model"]["noise_std"] == 0.1
    assert any("normalization='std'" in note for note in info.notes)
    assert any(f.endswith("config_data.yaml") for f in info.files)


def test_given_tokenizer_and_mismatches(tmp_path):
    released = write_discord(tmp_path / "DisCoRD", with_tokenizer=None)
    with pytest.raises(FileNotFoundError, match="pass tokenizer="):
        load_discord_decoder(released.folder)
    same_meta = write_momask(tmp_path / "rvq")
    for name in ("mean.npy", "std.npy"):
        (released.folder / "meta" / name).write_bytes((same_meta.folder / "meta" / name).read_bytes())
    decoder = load_discord_decoder(released.folder, tokenizer=load_momask_rvq(same_meta.folder))
    assert decoder.tokenizer.provenance.layout == "momask"

    wide = write_momask(tmp_path / "wide", VQSize(code_dim=32))
    with pytest.raises(ValueError, match="code_dim=32 does not match"):
        load_discord_decoder(released.folder, tokenizer=load_momask_rvq(wide.folder))
    other = write_momask(tmp_path / "other")
    np.save(other.folder / "meta" / "mean.npy", np.zeros(263))
    with pytest.raises(ValueError, match="differ from the tokenizer's normalisation"):
        load_discord_decoder(released.folder, tokenizer=load_momask_rvq(other.folder))
    assert load_discord_decoder(released.folder, tokenizer=load_momask_rvq(other.folder), check_meta=False) is not None


@pytest.mark.parametrize(
    ("where", "key", "value"),
    [
        ("Unet1D", "use_attention", True),
        ("Unet1D", "learned_variance", True),
        ("Unet1D", "random_fourier_features", True),
        ("Unet1D", "learned_sinusoidal_cond", True),
        ("Unet1D", "up_conv_c", "Transposed"),
        ("Unet1D", "resnet_per_block", 3),
        ("Unet1D", "sinusoidal_pos_emb_theta", 1000),
        ("DiT", "use", True),
        ("model", "Reflow", True),
    ],
)
def test_unsupported_settings_are_refused_by_name(tmp_path, where, key, value):
    model_yaml = discord_model_yaml(UNetSize())
    section = model_yaml["model"] if where == "model" else model_yaml["model"][where]
    section[key] = value
    released = write_discord(tmp_path / "DisCoRD", model_yaml=model_yaml, with_tokenizer=None)
    with pytest.raises(UnsupportedSettingError) as err:
        load_discord_decoder(released.folder)
    name = f"model.{key}" if where == "model" else f"model.{where}.{key}"
    assert f"{name}={value!r}" in str(err.value) and "config_model.yaml" in str(err.value)


def test_checkpoint_choice(tmp_path):
    released = write_discord(tmp_path / "DisCoRD")
    extra = released.folder / "checkpoints" / "RFDecoder_10_0.02_fid0.1_mpjpe0.01.pth"
    extra.write_bytes(released.checkpoint.read_bytes())
    assert load_discord_decoder(released.folder).provenance.files[2] == str(released.checkpoint)  # *_best*
    second_best = released.folder / "checkpoints" / "DisCoRD_Momask_RFDecoder_best.pth"
    second_best.write_bytes(released.checkpoint.read_bytes())
    with pytest.raises(CheckpointError) as err:
        load_discord_decoder(released.folder)
    assert "DisCoRD_Momask_RFDecoder_best.pth" in str(err.value) and "checkpoint=NAME" in str(err.value)
    chosen = load_discord_decoder(released.folder, checkpoint=extra.name)
    assert chosen.provenance.files[2] == str(extra)


def test_strict_keys_name_the_file(tmp_path):
    released = write_discord(tmp_path / "DisCoRD")
    state = {k.removeprefix("net."): v for k, v in released.state.items()}  # saved from the U-Net, not the wrapper
    torch.save(state, released.checkpoint)
    with pytest.raises(CheckpointError) as err:
        load_discord_decoder(released.folder)
    text = str(err.value)
    assert released.checkpoint.name in text and "missing keys" in text and "unexpected keys" in text
    assert "net.init_proj.weight" in text and "keys net.*" in text


def test_kit_sized_decoder(tmp_path):
    u = UNetSize(features=251)
    released = write_discord(tmp_path / "DisCoRD", u, with_tokenizer=None)
    tokenizer_folder = write_momask(tmp_path / "kit", VQSize(features=251), dataset="kit").folder
    for name in ("mean.npy", "std.npy"):
        (released.folder / "meta" / name).write_bytes((tokenizer_folder / "meta" / name).read_bytes())
    decoder = load_discord_decoder(released.folder, tokenizer=load_momask_rvq(tokenizer_folder))
    x, t, y = _inputs(u)
    with torch.no_grad():
        assert torch.allclose(decoder.velocity(x, t, y), official_unet(released.state, x, t, y, u), atol=ATOL)


def test_yaml_floats_like_omegaconf(tmp_path):
    model_yaml = discord_model_yaml(UNetSize())
    released = write_discord(tmp_path / "DisCoRD", model_yaml=model_yaml, with_tokenizer=None)
    path = released.folder / "configs" / "config_model.yaml"
    path.write_text(path.read_text().replace("dropout: 0.0", "dropout: 0e-3"))
    from motionlab.pretrained.files import read_yaml

    assert read_yaml(path)["model"]["Unet1D"]["dropout"] == 0.0
    assert yaml.safe_load(path.read_text())["model"]["Unet1D"]["dropout"] == "0e-3"  # plain PyYAML: a string


def test_keymap_is_invertible():
    for u in (UNetSize(), UNetSize(mults=(1, 2, 2), per_block=2, up_conv_c="Repeat_and_linear")):
        state = random_state(discord_manifest(u))
        keymap = discord_keymap(len(u.mults), u.per_block, u.up_conv_c)
        assert set(keymap.names) == set(state)
        back = keymap.to_official(keymap.to_motionlab(state))
        assert all(torch.equal(back[k], state[k]) for k in state)
