"""``check(path)``: what a pretrained folder is, what it holds and lacks, and whether it loads."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .converted import FILES as CONVERTED_FILES
from .discord import load_discord_weights, tokenizer_path
from .files import CheckpointError, read_yaml
from .layouts import LAYOUTS, default_meta, detect_layout, load
from .momask import LAYOUT_FILES, read_momask_options
from .t2mgpt import CHECKPOINT_NAMES

SHOWN = {  # the settings a report lists per layout (the module's provenance keeps all it read)
    "momask": ("dataset_name", "nb_code", "code_dim", "width", "depth", "down_t", "num_quantizers", "vq_act",
               "vq_norm"),
    "discord": ("output_dim", "dim", "dim_mults", "c_in_dim", "c_proj_dim", "up_conv_c", "resnet_per_block"),
    "converted": ("feature_dim", "width", "depth", "code_dim", "codebook_size", "num_layers", "width_mults",
                  "cond_dim", "projection", "resnets_per_level", "prediction", "normalization"),
}  # fmt: skip


@dataclass
class CheckReport:
    """The result of :func:`check`; ``str(report)`` is a readable summary."""

    path: Path
    layout: str | None
    found: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    config: dict[str, Any] = field(default_factory=dict)
    parameters: int | None = None
    loads: bool = False
    error: str | None = None
    notes: list[str] = field(default_factory=list)

    def __str__(self) -> str:
        kind = LAYOUTS.get(self.layout or "", "not a layout motionlab recognises")
        lines = [f"{self.path}: {kind}"]
        if self.found:
            lines.append("  found:   " + ", ".join(self.found))
        if self.missing:
            lines.append("  missing: " + ", ".join(self.missing))
        if self.config:
            lines.append("  config:  " + ", ".join(f"{k}={v!r}" for k, v in self.config.items()))
        if self.parameters is not None:
            lines.append(f"  parameters: {self.parameters:,}")
        lines.extend(f"  note: {note}" for note in self.notes)
        if self.loads:
            lines.append("  loads: yes")
        else:
            lines.append("  loads: no" + (": " + self.error.replace("\n", "\n    ") if self.error else ""))
        return "\n".join(lines)


def _expected_files(path: Path, layout: str | None, meta: Path | None) -> list[tuple[str, Path]]:
    if layout == "converted":
        return [(name, path / name) for name in CONVERTED_FILES]
    if layout in LAYOUT_FILES:
        options, ckpt_dir = LAYOUT_FILES[layout]
        names = [options, f"{ckpt_dir}/net_best_fid.tar", "meta/mean.npy", "meta/std.npy"]
        return [(name, path / name) for name in names]
    if layout == "t2mgpt":
        ckpt = path if path.is_file() else next((path / n for n in CHECKPOINT_NAMES if (path / n).is_file()), path)
        meta = meta if meta is not None else default_meta(path)
        return [(ckpt.name, ckpt), ("meta/mean.npy", meta / "mean.npy"), ("meta/std.npy", meta / "std.npy")]
    if layout == "discord":
        pths = sorted((path / "checkpoints").glob("*.pth")) or [path / "checkpoints" / "*.pth"]
        names = ["configs/config_model.yaml", "configs/config_data.yaml", "meta/mean.npy", "meta/std.npy"]
        return [(name, path / name) for name in names] + [(f"checkpoints/{p.name}", p) for p in pths]
    return []


def _read_settings(path: Path, layout: str | None) -> dict[str, Any]:
    """The settings as the folder states them (MoMask options, or the YAML's model section), flattened."""
    try:
        if layout in LAYOUT_FILES:
            return read_momask_options(path)[2]
        if layout == "discord":
            model = read_yaml(path / "configs" / "config_model.yaml").get("model") or {}
            return {**model, **(model.get("Unet1D") or {})}
    except (CheckpointError, FileNotFoundError):
        pass
    return {}


def _settings(path: Path, layout: str | None, module: Any) -> dict[str, Any]:
    if layout == "converted" and module is not None:
        return {k: getattr(module.config, k) for k in SHOWN["converted"] if hasattr(module.config, k)}
    if layout == "t2mgpt" and module is not None:
        return dict(module.provenance.config)  # sizes read off the state dict
    settings = _read_settings(path, layout)
    keys = SHOWN["momask"] if layout in LAYOUT_FILES else SHOWN.get(layout or "", ())
    return {k: settings[k] for k in keys if k in settings}


def check(path: str | os.PathLike, meta: str | os.PathLike | None = None) -> CheckReport:
    """Detect the layout of ``path``, list its files, read its config and try to load it (errors go in the report).

    A DisCoRD decoder is checked on its own weights; whether its tokenizer (``vqvae_weight_path``) is found is
    reported as a note.
    """
    path = Path(path)
    meta = Path(meta) if meta is not None else None
    layout = detect_layout(path)
    report = CheckReport(path=path, layout=layout)
    for name, file in _expected_files(path, layout, meta):
        (report.found if file.is_file() else report.missing).append(name)
    module = None
    try:
        if layout is None:
            load(path)  # raises, naming the layouts it knows
        elif layout == "discord":
            module, configs = load_discord_weights(path)
            found, tried = tokenizer_path(path, configs["model"])
            report.notes.append(
                f"tokenizer: {found}"
                if found
                else "tokenizer not found (pass tokenizer= to load it); "
                f"tried {', '.join(map(str, tried)) or 'nothing: no vqvae_weight_path'}"
            )
        else:
            module = load(path, meta=meta)
        report.loads = True
    except (CheckpointError, FileNotFoundError, ValueError) as err:
        report.error = str(err)
    report.config = _settings(path, layout, module)
    if module is not None:
        report.parameters = sum(p.numel() for p in module.parameters())
        report.notes.extend(module.provenance.notes)
    return report
