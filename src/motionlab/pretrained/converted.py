"""motionlab's own pickle-free layout for a loaded checkpoint, written by :func:`convert`::

    <out>/config.json          {"format": "motionlab-pretrained", "format_version": 1, "kind": ...,
                                "config": the motionlab config, "provenance": where it came from,
                                "tokenizer": "tokenizer" (a DisCoRD decoder's converted tokenizer) or null}
    <out>/model.safetensors    the motionlab module's state dict (motionlab's key names)
    <out>/meta/mean.npy, std.npy
    <out>/tokenizer/           (DisCoRD decoders) the same layout for the tokenizer

:func:`load_converted` reads it back with ``safetensors`` and ``np.load(allow_pickle=False)``: no pickle at all.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

from ..flow.config import DisCoRDConfig
from ..flow.discord import DisCoRDDecoder
from ..tokenizers import RVQVAE, VQVAE, RVQConfig, VQConfig
from .files import CheckpointError, load_normalizer, match_state_dict, require_files
from .info import PretrainedInfo, finish

FORMAT, FORMAT_VERSION = "motionlab-pretrained", 1
MODULES: dict[str, tuple[type, type]] = {  # provenance kind -> (module, config)
    "momask_rvq": (RVQVAE, RVQConfig),
    "t2mgpt_vq": (VQVAE, VQConfig),
    "discord_decoder": (DisCoRDDecoder, DisCoRDConfig),
}
FILES = ("config.json", "model.safetensors", "meta/mean.npy", "meta/std.npy")
HINT = "a converted folder holds " + ", ".join(FILES) + " as motionlab.pretrained.convert writes them"


def config_to_dict(config: Any) -> dict[str, Any]:
    return dataclasses.asdict(config)


def config_from_dict(cls: type, data: Mapping[str, Any], source: str) -> Any:
    """Rebuild a config dataclass from :func:`config_to_dict` output (nested dataclasses and tuples restored)."""
    names = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise CheckpointError(f"{source}: unknown {cls.__name__} field(s): {', '.join(unknown)}")
    kwargs = {}
    for name, value in data.items():
        f = names[name]
        default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
        if dataclasses.is_dataclass(default) and isinstance(value, Mapping):
            value = config_from_dict(type(default), value, source)
        elif isinstance(default, tuple) and isinstance(value, list):
            value = tuple(value)
        kwargs[name] = value
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as err:
        raise CheckpointError(f"{source}: invalid {cls.__name__}: {err}") from err


def write_converted(module: torch.nn.Module, out_dir: str | os.PathLike) -> Path:
    """Write a module loaded by this package (it has ``.normalizer`` and ``.provenance``) in the layout above."""
    out = Path(out_dir)
    info: PretrainedInfo | None = getattr(module, "provenance", None)
    if info is None or getattr(module, "normalizer", None) is None:
        raise ValueError("only modules loaded by motionlab.pretrained (with .normalizer and .provenance) convert")
    (out / "meta").mkdir(parents=True, exist_ok=True)
    state = {k: v.detach().cpu().contiguous() for k, v in module.state_dict().items()}
    save_file(state, str(out / "model.safetensors"), metadata={"format": FORMAT})
    np.save(out / "meta" / "mean.npy", module.normalizer.mean)
    np.save(out / "meta" / "std.npy", module.normalizer.std)
    tokenizer = getattr(module, "tokenizer", None) if info.kind == "discord_decoder" else None
    has_tokenizer = getattr(tokenizer, "provenance", None) is not None
    if has_tokenizer:
        write_converted(tokenizer, out / "tokenizer")
    document = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "kind": info.kind,
        "config": config_to_dict(module.config),
        "provenance": info.to_dict(),
        "tokenizer": "tokenizer" if has_tokenizer else None,
    }
    (out / "config.json").write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    return out


def is_converted(folder: Path) -> bool:
    return (folder / "config.json").is_file() and (folder / "model.safetensors").is_file()


def read_document(path: Path) -> dict[str, Any]:
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise CheckpointError(f"{path}: not a readable config.json: {err}") from err
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not a {FORMAT} config (format={document.get('format')!r})")
    if document.get("format_version") != FORMAT_VERSION or document.get("kind") not in MODULES:
        raise CheckpointError(
            f"{path}: unsupported format_version={document.get('format_version')!r} or kind={document.get('kind')!r}"
        )
    return document


def load_converted(folder: str | os.PathLike, tokenizer: Any = None, device: str | torch.device = "cpu"):
    """Load a folder :func:`write_converted` wrote (no pickle): the module, with ``.normalizer`` and ``.provenance``.

    A DisCoRD decoder is attached to ``tokenizer`` if given, else to the converted ``tokenizer/`` beside it.
    """
    folder = Path(folder)
    paths = require_files(folder, FILES, "converted motionlab-pretrained")
    document = read_document(paths["config.json"])
    module_cls, config_cls = MODULES[document["kind"]]
    config = config_from_dict(config_cls, document.get("config", {}), str(paths["config.json"]))
    module = module_cls(config)
    try:
        state = load_file(str(paths["model.safetensors"]))
    except (SafetensorError, OSError, ValueError) as err:
        raise CheckpointError(f"{paths['model.safetensors']}: not a readable safetensors file: {err}") from err
    expected = {k: tuple(v.shape) for k, v in module.state_dict().items()}
    match_state_dict(
        state, expected, paths["model.safetensors"], f"the {module_cls.__name__} config.json describes", HINT
    )
    try:
        module.load_state_dict(state, strict=True)
    except (RuntimeError, ValueError) as err:
        raise CheckpointError(f"{paths['model.safetensors']}: {err}") from err
    normalizer = load_normalizer(paths["meta/mean.npy"], paths["meta/std.npy"], config.feature_dim)
    original = PretrainedInfo.from_dict(document["provenance"])
    info = dataclasses.replace(
        original,
        layout="converted",
        files=tuple(paths.values()),
        notes=(*original.notes, f"converted from the {original.layout} layout: {', '.join(original.files)}"),
    )
    module = finish(module, normalizer, info, device)
    if document["kind"] == "discord_decoder":
        if tokenizer is None and document.get("tokenizer"):
            tokenizer = load_converted(folder / document["tokenizer"], device=device)
        if tokenizer is None:
            raise FileNotFoundError(f"{folder}: no converted tokenizer beside the decoder; pass tokenizer=")
        module.attach(tokenizer)
    return module
