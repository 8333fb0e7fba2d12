"""MoMask's residual VQ-VAE (the tokenizer DisCoRD decodes), loaded from its released folder.

Two layouts hold the same checkpoint::

    MoMask   checkpoints/<t2m|kit>/<name>/opt.txt                 argparse dump, `key: value` per line
                                      /model/net_best_fid.tar     torch.save dict: vq_model (or net), ep,
                                                                   total_it, opt_vq_model, scheduler
                                      /meta/mean.npy, std.npy     the normalisation it was trained with
    DisCoRD  checkpoints/Momask/configs/config_model.yaml         the same options as YAML (model: {...})
                               /checkpoints/net_best_fid.tar
                               /meta/mean.npy, std.npy

The returned :class:`~motionlab.tokenizers.RVQVAE` encodes and decodes features normalised with ``meta`` (its
``normalizer``), as MoMask's ``encode`` / ``forward_decoder`` do; ids are ``(B, T/4, num_quantizers)``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from ..tokenizers import RVQVAE, RVQConfig
from .files import (
    CheckpointError,
    UnsupportedSettingError,
    as_float,
    as_int,
    load_normalizer,
    load_torch_file,
    read_opt_txt,
    read_yaml,
    refuse,
    require_files,
    state_dict_in,
)
from .info import PretrainedInfo, epoch_and_iteration, finish
from .keymaps import load_official, momask_rvq_keymap

# The datasets MoMask knows (utils/get_opt.py): feature size and joints.
DATASETS = {"t2m": (263, 22), "kit": (251, 21)}

# options/vq_option.py defaults, used for an option the file does not list (the notes say which).
MOMASK_DEFAULTS: dict[str, Any] = {
    "nb_code": 512,
    "code_dim": 512,
    "output_emb_width": 512,
    "down_t": 2,
    "stride_t": 2,
    "width": 512,
    "depth": 3,
    "dilation_growth_rate": 3,
    "vq_act": "relu",
    "vq_norm": "None",
    "num_quantizers": 3,
    "shared_codebook": False,
    "quantize_dropout_prob": 0.2,
    "mu": 0.99,
    "window_size": 64,
    "batch_size": 256,
}
MOMASK_RESBLOCK_DROPOUT = 0.2  # ResConv1DBlock's default, not an option
MOMASK_GUMBEL_TEMPERATURE = 0.5  # RVQVAE.forward: sample_codebook_temp=0.5 while training

# layout -> (options file, checkpoint folder)
LAYOUT_FILES = {"momask": ("opt.txt", "model"), "discord-momask": ("configs/config_model.yaml", "checkpoints")}

LAYOUT_HINT = (
    "a MoMask RVQ folder holds opt.txt, model/net_best_fid.tar (a torch.save dict with the state dict under "
    "'vq_model' or 'net'), meta/mean.npy and meta/std.npy (or DisCoRD's copy: configs/config_model.yaml, "
    "checkpoints/net_best_fid.tar, meta/)"
)


def momask_layout(folder: Path) -> str | None:
    """``"momask"`` (opt.txt), ``"discord-momask"`` (DisCoRD's YAML copy), or None."""
    if (folder / "opt.txt").is_file():
        return "momask"
    config = folder / "configs" / "config_model.yaml"
    if config.is_file():
        try:
            name = read_yaml(config).get("model", {}).get("name")
        except (CheckpointError, AttributeError):
            return None
        if isinstance(name, str) and name.startswith("Momask"):
            return "discord-momask"
    return None


def read_momask_options(folder: Path) -> tuple[str, Path, dict[str, Any]]:
    """``(layout, options file, options)`` of a MoMask tokenizer folder (either layout)."""
    layout = momask_layout(folder)
    if layout == "momask":
        return layout, folder / "opt.txt", read_opt_txt(folder / "opt.txt")
    if layout == "discord-momask":
        path = folder / "configs" / "config_model.yaml"
        options = read_yaml(path).get("model")
        if not isinstance(options, dict):
            raise CheckpointError(f"{path}: expected a 'model:' mapping of MoMask options")
        if options.get("name") != "Momask_RVQVAE":
            raise refuse(str(path), "model.name", options.get("name"), "Momask_RVQVAE, MoMask's residual VQ-VAE")
        return layout, path, dict(options)
    raise FileNotFoundError(f"{folder}: no opt.txt or configs/config_model.yaml; {LAYOUT_HINT}")


def momask_rvq_config(options: Mapping[str, Any], source: str = "opt.txt") -> tuple[RVQConfig, list[str]]:
    """Map MoMask's options to an :class:`~motionlab.tokenizers.RVQConfig`; refuse what motionlab lacks.

    Returns the config and notes (options that were absent and took ``vq_option.py``'s default).
    """
    notes = [f"{k} not in {source}: MoMask's default {v!r}" for k, v in MOMASK_DEFAULTS.items() if k not in options]
    opt = {**MOMASK_DEFAULTS, **options}
    dataset = opt.get("dataset_name")
    if dataset not in DATASETS:
        raise refuse(source, "dataset_name", dataset, "MoMask's 't2m' (263 features) and 'kit' (251)")
    feature_dim, joints = DATASETS[dataset]
    ints = {k: as_int(opt[k], source, k) for k, v in MOMASK_DEFAULTS.items() if type(v) is int}
    for key in ("down_t", "stride_t"):
        if ints[key] != 2:
            raise refuse(source, key, opt[key], "two stride-2 stages: down_t=2, stride_t=2 (4 frames per token)")
    if opt["vq_act"] != "relu":
        raise refuse(source, "vq_act", opt["vq_act"], "vq_act='relu'")
    if opt["vq_norm"] not in (None, "None"):
        raise refuse(source, "vq_norm", opt["vq_norm"], "no normalisation in the residual blocks (vq_norm=None)")
    if opt["shared_codebook"] not in (False, "False"):
        raise refuse(
            source, "shared_codebook", opt["shared_codebook"], "one codebook per layer (shared_codebook=False)"
        )
    if ints["output_emb_width"] != ints["code_dim"]:
        raise refuse(
            source, "output_emb_width", opt["output_emb_width"], f"output_emb_width == code_dim ({ints['code_dim']})"
        )
    if ints["num_quantizers"] < 1:
        raise refuse(source, "num_quantizers", opt["num_quantizers"], "num_quantizers >= 1")
    try:
        config = RVQConfig(
            feature_dim=feature_dim,
            n_joints=joints,
            width=ints["width"],
            depth=ints["depth"],
            dilation_growth=ints["dilation_growth_rate"],
            dropout=MOMASK_RESBLOCK_DROPOUT,
            code_dim=ints["code_dim"],
            codebook_size=ints["nb_code"],
            ema_decay=as_float(opt["mu"], source, "mu"),
            gumbel_temperature=MOMASK_GUMBEL_TEMPERATURE,
            window=ints["window_size"],
            batch_size=ints["batch_size"],
            num_layers=ints["num_quantizers"],
            quantize_dropout=as_float(opt["quantize_dropout_prob"], source, "quantize_dropout_prob"),
        )
    except ValueError as err:
        raise UnsupportedSettingError(f"{source}: {err}") from err
    return config, notes


def load_momask_rvq(
    folder: str | os.PathLike, device: str | torch.device = "cpu", checkpoint: str = "net_best_fid.tar"
) -> RVQVAE:
    """Load MoMask's released residual VQ-VAE from ``folder`` (either layout above) into an ``RVQVAE``.

    ``checkpoint``: the file in ``model/`` (MoMask) or ``checkpoints/`` (DisCoRD's copy), e.g. ``latest.tar``.
    The model comes back in eval mode with ``.normalizer`` (``meta/mean.npy``, ``std.npy``) and ``.provenance``.
    Raises ``FileNotFoundError`` naming missing files, :class:`CheckpointError` for a file that does not hold a
    matching state dict, :class:`UnsupportedSettingError` for options motionlab does not implement.
    """
    folder = Path(folder)
    layout = momask_layout(folder) or "momask"  # an incomplete folder is reported against MoMask's own layout
    options_file, ckpt_dir = LAYOUT_FILES[layout]
    paths = require_files(
        folder, [options_file, f"{ckpt_dir}/{checkpoint}", "meta/mean.npy", "meta/std.npy"], "MoMask RVQ"
    )
    layout, options_path, options = read_momask_options(folder)
    config, notes = momask_rvq_config(options, str(options_path))

    ckpt_path = paths[f"{ckpt_dir}/{checkpoint}"]
    raw = load_torch_file(ckpt_path)
    official = state_dict_in(raw, ckpt_path, ("vq_model", "net"), "MoMask RVQ checkpoint")
    model = RVQVAE(config)
    keymap = momask_rvq_keymap(config.depth, config.num_layers)
    load_official(model, official, keymap, ckpt_path, _describe(config), LAYOUT_HINT)

    normalizer = load_normalizer(paths["meta/mean.npy"], paths["meta/std.npy"], config.feature_dim)
    epoch, iteration = epoch_and_iteration(raw)
    info = PretrainedInfo(
        kind="momask_rvq",
        layout=layout,
        files=tuple(paths.values()),
        epoch=epoch,
        iteration=iteration,
        config=options,
        notes=tuple(notes),
    )
    return finish(model, normalizer, info, device)


def _describe(config: RVQConfig) -> str:
    return (
        f"a MoMask residual VQ-VAE with {config.feature_dim} features, width={config.width}, depth={config.depth}, "
        f"code_dim={config.code_dim}, nb_code={config.codebook_size}, num_quantizers={config.num_layers}"
    )
