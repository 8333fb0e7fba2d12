"""Which layout a path is, and one entry point that loads any of them: :func:`load`, :func:`convert`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import torch

from .converted import is_converted, load_converted, write_converted
from .discord import load_discord_decoder
from .files import CheckpointError, read_yaml
from .momask import load_momask_rvq, momask_layout
from .t2mgpt import CHECKPOINT_NAMES, load_t2mgpt_vq

LAYOUTS = {
    "converted": "motionlab's converted layout (config.json, model.safetensors, meta/)",
    "momask": "MoMask residual VQ-VAE (opt.txt, model/*.tar, meta/)",
    "discord-momask": "DisCoRD's copy of the MoMask RVQ (configs/config_model.yaml, checkpoints/*.tar, meta/)",
    "t2mgpt": "T2M-GPT VQ-VAE (net_last.pth / net_best_fid.pth; meta passed separately)",
    "discord": "DisCoRD decoder (configs/config_model.yaml with RFDecoder, checkpoints/*.pth, meta/)",
}


def detect_layout(path: str | os.PathLike) -> str | None:
    """One of :data:`LAYOUTS`, or None when ``path`` looks like none of them."""
    path = Path(path)
    if path.is_file():
        return "t2mgpt" if path.suffix == ".pth" else None
    if not path.is_dir():
        return None
    if is_converted(path):
        return "converted"
    layout = momask_layout(path)
    if layout is not None:
        return layout
    config = path / "configs" / "config_model.yaml"
    if config.is_file():
        try:
            model = read_yaml(config).get("model")
        except CheckpointError:
            return None
        return "discord" if isinstance(model, dict) and model.get("name") == "RFDecoder" else None
    if any((path / name).is_file() for name in CHECKPOINT_NAMES):
        return "t2mgpt"
    return None


def default_meta(path: Path) -> Path:
    """Where a T2M-GPT checkpoint's ``meta`` is looked for when none is given: ``meta/`` beside the file."""
    folder = path.parent if path.is_file() else path
    return folder / "meta"


def load(
    path: str | os.PathLike,
    *,
    meta: str | os.PathLike | None = None,
    tokenizer: Any = None,
    device: str | torch.device = "cpu",
    checkpoint: str | None = None,
) -> torch.nn.Module:
    """Load a released or converted checkpoint, whichever layout ``path`` is (see :func:`detect_layout`).

    ``meta``: T2M-GPT's normalisation folder (default ``meta/`` beside the checkpoint); ``tokenizer``: for a
    DisCoRD decoder; ``checkpoint``: a file name inside a MoMask / DisCoRD folder.
    """
    path = Path(path)
    layout = detect_layout(path)
    if layout == "converted":
        return load_converted(path, tokenizer=tokenizer, device=device)
    if layout in ("momask", "discord-momask"):
        return load_momask_rvq(path, device=device, **({"checkpoint": checkpoint} if checkpoint else {}))
    if layout == "t2mgpt":
        return load_t2mgpt_vq(path, meta if meta is not None else default_meta(path), device=device)
    if layout == "discord":
        return load_discord_decoder(path, tokenizer=tokenizer, device=device, checkpoint=checkpoint)
    expected = "\n  ".join(f"{name}: {text}" for name, text in LAYOUTS.items())
    raise FileNotFoundError(f"{path}: not a pretrained checkpoint motionlab recognises; expected one of\n  {expected}")


def convert(
    path: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    meta: str | os.PathLike | None = None,
    tokenizer: Any = None,
    checkpoint: str | None = None,
    overwrite: bool = False,
) -> Path:
    """Load ``path`` (any layout) and write it to ``out_dir`` as ``config.json`` + ``model.safetensors`` + ``meta/``
    (a DisCoRD decoder also writes its tokenizer to ``out_dir/tokenizer``); :func:`load` reads it without pickle.

    A non-empty ``out_dir`` is refused unless ``overwrite``."""
    out = Path(out_dir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not overwrite:
        raise FileExistsError(f"{out} exists and is not empty; choose a new folder (or overwrite=True)")
    module = load(path, meta=meta, tokenizer=tokenizer, checkpoint=checkpoint)
    return write_converted(module, out_dir)
