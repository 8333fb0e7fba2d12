"""T2M-GPT's VQ-VAE (one EMA codebook; also M2D2M's tokenizer), loaded from its released ``.pth``.

Layout (T2M-GPT README): ``pretrained/VQVAE/net_last.pth`` (or ``net_best_fid.pth``), a ``torch.save`` of
``{'net': HumanVQVAE.state_dict()}``; the normalisation it was trained with lives elsewhere, in the evaluator's
``meta`` folder (``mean.npy``, ``std.npy``), so it is passed separately.

No config file ships with it: the sizes are read off the state dict (feature size and width from the first
convolution, codebook size and code width from the codebook, depth from the residual blocks); what shapes cannot
tell (the dilation growth rate) takes the published value.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import torch

from ..tokenizers import VQVAE, VQConfig
from .files import (
    UnsupportedSettingError,
    load_normalizer,
    load_torch_file,
    refuse,
    state_dict_in,
)
from .info import PretrainedInfo, epoch_and_iteration, finish
from .keymaps import load_official, t2mgpt_vq_keymap

CHECKPOINT_NAMES = ("net_last.pth", "net_best_fid.pth")  # what T2M-GPT's scripts load, in that order
PUBLISHED_DILATION_GROWTH = 3  # options/option_vq.py; a dilation is not stored in the weights
LAYOUT_HINT = (
    "a T2M-GPT VQ checkpoint is net_last.pth / net_best_fid.pth holding {'net': state dict} with keys "
    "vqvae.encoder.model.*, vqvae.decoder.model.*, vqvae.quantizer.codebook; meta is a folder with mean.npy, std.npy"
)


def find_t2mgpt_checkpoint(path: Path) -> Path:
    """``path`` itself if a file, else the first of :data:`CHECKPOINT_NAMES` in it."""
    if path.is_file():
        return path
    for name in CHECKPOINT_NAMES:
        if (path / name).is_file():
            return path / name
    raise FileNotFoundError(
        f"no T2M-GPT VQ checkpoint at {path}: expected a .pth file or a folder with one of "
        f"{', '.join(CHECKPOINT_NAMES)}"
    )


def find_meta(meta: Path) -> tuple[Path, Path]:
    """``mean.npy`` / ``std.npy`` in ``meta`` (also accepts HumanML3D's ``Mean.npy`` / ``Std.npy``)."""
    for mean, std in (("mean.npy", "std.npy"), ("Mean.npy", "Std.npy")):
        if (meta / mean).is_file() and (meta / std).is_file():
            return meta / mean, meta / std
    raise FileNotFoundError(f"{meta}: missing mean.npy and std.npy (the normalisation the VQ-VAE was trained with)")


def t2mgpt_vq_sizes(state: dict[str, Any], path: Path) -> tuple[dict[str, int], list[str]]:
    """The sizes a ``HumanVQVAE`` state dict implies (published defaults for what it does not show), and notes."""
    sizes = {"feature_dim": 263, "width": 512, "depth": 3, "code_dim": 512, "nb_code": 512, "down_t": 2}
    notes = [f"dilation_growth_rate is not stored in the weights: published {PUBLISHED_DILATION_GROWTH}"]
    first, codebook = state.get("vqvae.encoder.model.0.weight"), state.get("vqvae.quantizer.codebook")
    if isinstance(first, torch.Tensor) and first.dim() == 3:
        sizes["width"], sizes["feature_dim"] = int(first.shape[0]), int(first.shape[1])
    else:
        notes.append("vqvae.encoder.model.0.weight absent: published width 512 and 263 features")
    if isinstance(codebook, torch.Tensor) and codebook.dim() == 2:
        sizes["nb_code"], sizes["code_dim"] = int(codebook.shape[0]), int(codebook.shape[1])
    else:
        notes.append("vqvae.quantizer.codebook absent: published 512 codes of width 512")
    blocks = {
        int(m.group(1)) for k in state if (m := re.fullmatch(r"vqvae\.encoder\.model\.2\.1\.model\.(\d+)\..*", k))
    }
    if blocks:
        sizes["depth"] = max(blocks) + 1
    stages = {int(m.group(1)) for k in state if (m := re.fullmatch(r"vqvae\.encoder\.model\.(\d+)\.0\.weight", k))}
    if stages:
        sizes["down_t"] = len(stages)
    if sizes["down_t"] != 2:
        raise refuse(str(path), "down_t", sizes["down_t"], "two stride-2 stages (down_t=2, 4 frames per token)")
    last = state.get("vqvae.encoder.model.4.weight")
    if isinstance(last, torch.Tensor) and last.dim() == 3 and last.shape[0] != sizes["code_dim"]:
        raise refuse(
            str(path), "output_emb_width", int(last.shape[0]), f"output_emb_width == code_dim ({sizes['code_dim']})"
        )
    return sizes, notes


def t2mgpt_vq_config(sizes: dict[str, int], source: str) -> VQConfig:
    """The :class:`~motionlab.tokenizers.VQConfig` of those sizes (no dropout in T2M-GPT's residual blocks)."""
    joints, rest = divmod(sizes["feature_dim"] + 1, 12)  # D = 12·J − 1 (root 4, ric/rot/vel, feet 4)
    if rest or joints < 2:
        raise refuse(source, "feature_dim", sizes["feature_dim"], "HumanML3D-style features, 12·joints − 1 (263, 251)")
    try:
        return VQConfig(
            feature_dim=sizes["feature_dim"],
            n_joints=joints,
            width=sizes["width"],
            depth=sizes["depth"],
            dilation_growth=PUBLISHED_DILATION_GROWTH,
            dropout=0.0,
            code_dim=sizes["code_dim"],
            codebook_size=sizes["nb_code"],
        )
    except ValueError as err:
        raise UnsupportedSettingError(f"{source}: {err}") from err


def load_t2mgpt_vq(path: str | os.PathLike, meta: str | os.PathLike, device: str | torch.device = "cpu") -> VQVAE:
    """Load T2M-GPT's released VQ-VAE (``path``: the ``.pth`` or its folder) into a motionlab ``VQVAE``.

    ``meta``: the folder with the ``mean.npy`` / ``std.npy`` T2M-GPT normalises with. The model comes back in
    eval mode with ``.normalizer`` and ``.provenance``; ids are ``(B, T/4)``.
    """
    ckpt_path = find_t2mgpt_checkpoint(Path(path))
    mean_path, std_path = find_meta(Path(meta))
    raw = load_torch_file(ckpt_path)
    official = state_dict_in(raw, ckpt_path, ("net",), "T2M-GPT VQ checkpoint")
    sizes, notes = t2mgpt_vq_sizes(official, ckpt_path)
    config = t2mgpt_vq_config(sizes, str(ckpt_path))
    model = VQVAE(config)
    what = (
        f"a T2M-GPT VQ-VAE with {config.feature_dim} features, width={config.width}, depth={config.depth}, "
        f"code_dim={config.code_dim}, nb_code={config.codebook_size}"
    )
    load_official(model, official, t2mgpt_vq_keymap(config.depth), ckpt_path, what, LAYOUT_HINT)
    normalizer = load_normalizer(mean_path, std_path, config.feature_dim)
    epoch, iteration = epoch_and_iteration(raw)
    info = PretrainedInfo(
        kind="t2mgpt_vq",
        layout="t2mgpt",
        files=(ckpt_path, mean_path, std_path),
        epoch=epoch,
        iteration=iteration,
        config={**sizes, "dilation_growth_rate": PUBLISHED_DILATION_GROWTH},
        notes=tuple(notes),
    )
    return finish(model, normalizer, info, device)
