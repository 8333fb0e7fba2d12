"""DisCoRD's rectified-flow decoder, loaded from the folder ``train_rf_decoder_from_vqvae.py`` writes::

    <run>/configs/config_model.yaml    model: {name: RFDecoder, output_dim, Unet1D: {...}, DiT: {use: false},
                                               vqvae_weight_path: the MoMask tokenizer whose codes it decodes}
    <run>/configs/config_data.yaml     the dataset paths it trained on (optional here; kept in the provenance)
    <run>/checkpoints/*.pth            torch.save(RectifiedFlowDecoder.state_dict()): every key under ``net.``
    <run>/meta/mean.npy, std.npy       copied from the tokenizer's meta

What the released weights mean, read from the official code (``whwjdqls/DisCoRD``):

- ``RectifiedFlowDecoder(model=denoiser)`` keeps its defaults ``predict='flow'``, ``noise_schedule=identity``:
  the network outputs the velocity, at times ``t ~ U(0, 1)`` passed as is (``rectified_flow.py``:
  ``noised = t·data + (1 − t)·noise``, target ``data − noise``) → ``prediction="v"``,
  ``time_distribution="uniform"``.
- The training windows are normalised with the tokenizer's own ``meta`` mean/std, and ``data_cfg.feat_bias`` is
  forced to 1.0 (``train_rf_decoder_from_vqvae.py``: "we want to use the same mean, std as the vae"): the flow
  runs in exactly the tokenizer's normalised feature space, with no further per-group scaling →
  ``normalization="std"``. (The root/foot-contact reweighting MoMask's ``feat_bias`` does is already inside
  those ``meta`` files; motionlab's ``"feat_bias"`` mode would apply it a second time.)
- Sampling: ``torchdiffeq.odeint(..., torch.linspace(0, 1, 16), method='midpoint')`` from ``N(0, I)`` noise
  (``sample(steps=16)``, ``MotionPriorWrapper.num_sample_steps = 16``) → 15 midpoint intervals, uniform grid,
  temperature 1.
- ``noise_std`` in the YAML is not read by the decoder code; it is kept in the provenance only.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from ..flow.config import DisCoRDConfig
from ..flow.discord import DisCoRDDecoder
from .files import (
    CheckpointError,
    UnsupportedSettingError,
    as_float,
    as_int,
    load_normalizer,
    load_torch_file,
    read_yaml,
    refuse,
    require_files,
    state_dict_in,
)
from .info import PretrainedInfo, finish
from .keymaps import DISCORD_PROJECTIONS, discord_keymap, load_official
from .momask import load_momask_rvq

# The settings the official code trains and samples with (see the module docstring).
RELEASED_PARAMETERISATION = dict(
    prediction="v", normalization="std", time_distribution="uniform", sample_steps=15, solver="midpoint",
    spacing="uniform", temperature=1.0, final_prediction=False,
)  # fmt: skip
TIME_THETA = 10000  # motionlab's U-Net uses this sinusoidal base
LAYOUT_HINT = (
    "a DisCoRD decoder folder holds configs/config_model.yaml, checkpoints/*.pth (a plain state dict of "
    "RectifiedFlowDecoder, keys net.*), meta/mean.npy and meta/std.npy"
)


def discord_config(model_cfg: Mapping[str, Any], source: str = "config_model.yaml") -> tuple[DisCoRDConfig, str]:
    """The :class:`~motionlab.flow.DisCoRDConfig` a DisCoRD ``config_model.yaml`` describes, and its ``up_conv_c``.

    Refuses (:class:`UnsupportedSettingError`, naming the setting) what motionlab's U-Net does not implement.
    """
    model = model_cfg.get("model") if isinstance(model_cfg, Mapping) else None
    if not isinstance(model, Mapping):
        raise CheckpointError(f"{source}: expected a 'model:' mapping")
    if model.get("name") != "RFDecoder":
        raise refuse(source, "model.name", model.get("name"), "'RFDecoder', the rectified-flow decoder")
    dit = model.get("DiT") if isinstance(model.get("DiT"), Mapping) else {}
    if dit.get("use", False):
        raise refuse(source, "model.DiT.use", dit.get("use"), "the 1D U-Net backbone (DiT.use: false)")
    for flag in ("text_condition", "Reflow"):
        if model.get(flag, False):
            raise refuse(source, f"model.{flag}", model.get(flag), f"{flag}: false (the released decoder)")
    unet = model.get("Unet1D")
    if not isinstance(unet, Mapping) or not unet.get("use", False):
        raise refuse(
            source, "model.Unet1D.use", None if unet is None else unet.get("use"), "the 1D U-Net (Unet1D.use: true)"
        )
    for key in ("use_attention", "learned_variance", "learned_sinusoidal_cond", "random_fourier_features"):
        if unet.get(key, False):
            raise refuse(source, f"model.Unet1D.{key}", unet.get(key), f"{key}: false")
    theta = as_float(unet.get("sinusoidal_pos_emb_theta", TIME_THETA), source, "model.Unet1D.sinusoidal_pos_emb_theta")
    if theta != TIME_THETA:
        raise refuse(source, "model.Unet1D.sinusoidal_pos_emb_theta", theta, f"theta {TIME_THETA}")
    up_conv_c = unet.get("up_conv_c", False)  # absent: the official default False, i.e. its "Upsample" stack
    if up_conv_c not in DISCORD_PROJECTIONS:
        raise refuse(source, "model.Unet1D.up_conv_c", up_conv_c, f"up_conv_c in {sorted(DISCORD_PROJECTIONS)}")
    k = as_int(unet.get("resnet_per_block", 1), source, "model.Unet1D.resnet_per_block")
    if k not in (1, 2):  # the official forward unpacks one or two blocks per level
        raise refuse(source, "model.Unet1D.resnet_per_block", k, "resnet_per_block 1 or 2")
    mults = unet.get("dim_mults")
    if not isinstance(mults, (list, tuple)) or not mults:
        raise CheckpointError(f"{source}: model.Unet1D.dim_mults must be a list of integers, found {mults!r}")
    try:
        config = DisCoRDConfig(
            feature_dim=as_int(model.get("output_dim"), source, "model.output_dim"),
            code_dim=as_int(unet.get("c_in_dim"), source, "model.Unet1D.c_in_dim"),
            q=4,  # repeat_interleave(4) and StackLinear(quant_factor=2) are fixed in the official U-Net
            cond_dim=as_int(unet.get("c_proj_dim"), source, "model.Unet1D.c_proj_dim"),
            projection=DISCORD_PROJECTIONS[up_conv_c],
            width=as_int(unet.get("dim"), source, "model.Unet1D.dim"),
            width_mults=tuple(as_int(m, source, "model.Unet1D.dim_mults") for m in mults),
            resnets_per_level=k,
            dropout=as_float(unet.get("dropout", 0.0), source, "model.Unet1D.dropout"),
            **RELEASED_PARAMETERISATION,
        )
    except ValueError as err:
        if isinstance(err, CheckpointError):
            raise
        raise UnsupportedSettingError(f"{source}: {err}") from err
    return config, up_conv_c


def choose_checkpoint(folder: Path, name: str | None = None) -> Path:
    """``checkpoints/<name>``, else the only ``*.pth`` there, else the only ``*_best*.pth``; else an error listing
    them."""
    directory = folder / "checkpoints"
    if name is not None:
        path = directory / name if (directory / name).is_file() else Path(name)
        if not path.is_file():
            raise FileNotFoundError(f"{folder}: no checkpoint {name!r} in checkpoints/")
        return path
    found = sorted(directory.glob("*.pth"))
    if not found:
        raise FileNotFoundError(f"{folder}: no checkpoints/*.pth; {LAYOUT_HINT}")
    best = [p for p in found if "_best" in p.stem]
    if len(found) == 1 or len(best) == 1:
        return found[0] if len(found) == 1 else best[0]
    names = ", ".join(p.name for p in (best or found))
    raise CheckpointError(f"{directory}: several checkpoints ({names}); choose one with checkpoint=NAME")


def load_discord_weights(
    folder: str | os.PathLike, checkpoint: str | None = None
) -> tuple[DisCoRDDecoder, dict[str, Any]]:
    """The decoder with its weights, normaliser and provenance, not yet attached to a tokenizer (eval mode, CPU);
    and the configs read."""
    folder = Path(folder)
    paths = require_files(folder, ["configs/config_model.yaml", "meta/mean.npy", "meta/std.npy"], "DisCoRD decoder")
    ckpt_path = choose_checkpoint(folder, checkpoint)
    model_cfg = read_yaml(paths["configs/config_model.yaml"])
    data_path = folder / "configs" / "config_data.yaml"
    data_cfg = read_yaml(data_path) if data_path.is_file() else None
    config, up_conv_c = discord_config(model_cfg, str(paths["configs/config_model.yaml"]))

    decoder = DisCoRDDecoder(config)
    official = state_dict_in(load_torch_file(ckpt_path), ckpt_path, (), "RectifiedFlowDecoder state dict")
    what = (
        f"a DisCoRD U-Net decoder with {config.feature_dim} features, dim={config.width}, "
        f"dim_mults={list(config.width_mults)}, c_in_dim={config.code_dim}, c_proj_dim={config.cond_dim}, "
        f"resnet_per_block={config.resnets_per_level}, up_conv_c={up_conv_c}"
    )
    keymap = discord_keymap(len(config.width_mults), config.resnets_per_level, up_conv_c)
    load_official(decoder, official, keymap, ckpt_path, what, LAYOUT_HINT)
    normalizer = load_normalizer(paths["meta/mean.npy"], paths["meta/std.npy"], config.feature_dim)
    model = model_cfg["model"]
    info = PretrainedInfo(
        kind="discord_decoder",
        layout="discord",
        files=(
            paths["configs/config_model.yaml"],
            *([data_path] if data_cfg is not None else []),
            ckpt_path,
            paths["meta/mean.npy"],
            paths["meta/std.npy"],
        ),
        config={"model": model_cfg, "data": data_cfg},
        notes=(
            "prediction='v' (RectifiedFlowDecoder predict='flow'), time t ~ U(0, 1) used as is",
            "normalization='std': trained on the tokenizer's meta-normalised features (feat_bias forced to 1.0)",
            "sampling: odeint midpoint on linspace(0, 1, 16) = 15 midpoint intervals from N(0, I)",
            f"noise_std={model.get('noise_std')!r} is not read by the RF decoder code",
        ),
    )
    return finish(decoder, normalizer, info, "cpu"), {"model": model_cfg, "data": data_cfg}


def tokenizer_path(folder: Path, model_cfg: Mapping[str, Any]) -> tuple[Path | None, list[Path]]:
    """Where ``model.vqvae_weight_path`` points, trying it relative to the folder, its parents and the working
    directory (the official scripts run from the repository root); ``(found or None, paths tried)``."""
    weight = (model_cfg.get("model") or {}).get("vqvae_weight_path")
    if not isinstance(weight, str) or not weight:
        return None, []
    path = Path(weight)
    roots = [folder, folder.parent, folder.parent.parent, Path.cwd()]
    tried = list(dict.fromkeys([path] if path.is_absolute() else [root / path for root in roots]))
    return next((p for p in tried if p.is_file()), None), tried


def load_discord_decoder(
    folder: str | os.PathLike,
    tokenizer: Any = None,
    device: str | torch.device = "cpu",
    checkpoint: str | None = None,
    check_meta: bool = True,
) -> DisCoRDDecoder:
    """Load DisCoRD's released decoder from ``folder`` into a motionlab ``DisCoRDDecoder`` attached to its tokenizer.

    ``tokenizer``: the loaded tokenizer whose codes it decodes; if None, the YAML's ``vqvae_weight_path`` is
    resolved (see :func:`tokenizer_path`) and loaded with :func:`~.momask.load_momask_rvq` from the folder two
    levels up (DisCoRD's convention). ``checkpoint``: a file name in ``checkpoints/`` (default: the only one, or
    the only ``*_best*``). ``check_meta``: require the decoder's ``meta`` to equal ``tokenizer.normalizer``.

    ``decoder.velocity(x_t, t, code_vectors)`` and ``decoder.decode(ids)`` work on features normalised with
    ``decoder.normalizer``, as the official ``RectifiedFlowDecoder`` does.
    """
    folder = Path(folder)
    decoder, configs = load_discord_weights(folder, checkpoint)
    if tokenizer is None:
        found, tried = tokenizer_path(folder, configs["model"])
        if found is None:
            where = "; tried " + ", ".join(map(str, tried)) if tried else " (no model.vqvae_weight_path in the YAML)"
            raise FileNotFoundError(f"{folder}: the decoder's tokenizer was not found{where}; pass tokenizer=")
        tokenizer = load_momask_rvq(found.parent.parent, device=device, checkpoint=found.name)
    try:
        decoder.attach(tokenizer)
    except ValueError as err:
        raise ValueError(f"{folder}: the tokenizer does not fit this decoder: {err}") from err
    theirs = getattr(tokenizer, "normalizer", None)
    if check_meta and theirs is not None and not _same_normalizer(decoder.normalizer, theirs):
        raise ValueError(
            f"{folder}: meta/mean.npy, std.npy differ from the tokenizer's normalisation; the decoder runs in the "
            "tokenizer's normalised features, so they must agree (check_meta=False to attach anyway)"
        )
    return decoder.to(device).eval()


def _same_normalizer(a: Any, b: Any) -> bool:
    return a.mean.shape == b.mean.shape and bool(
        np.allclose(a.mean, b.mean, rtol=1e-5, atol=1e-6) and np.allclose(a.std, b.std, rtol=1e-5, atol=1e-6)
    )
