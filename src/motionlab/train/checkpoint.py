"""Checkpoints that a crash cannot half-write, holding everything needed to resume bit-identically.

A checkpoint is a folder ``step_00001234/`` with

- ``model.safetensors`` (and ``ema.safetensors``): the weights, loadable without pickle;
- ``state.pt``: optimizer moments and every RNG state (torch's global RNG, CUDA's, the trainer's generators);
- ``meta.json``: step, config and history, readable by a human.

Each folder is written under a temporary name and renamed into place, so a folder with a final name is
always complete.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import uuid
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import load_file, save_file
from torch import nn

from .ema import EMA

_STEP_DIR = re.compile(r"^step_(\d{8})$")


def save_weights(state: dict[str, torch.Tensor], path: Path) -> None:
    """Write a state dict as safetensors (cloned, so tied or non-contiguous tensors are fine)."""
    save_file({k: v.detach().to("cpu").clone().contiguous() for k, v in state.items()}, str(path))


def load_weights(model: nn.Module, path: str | os.PathLike) -> None:
    """Load safetensors weights into ``model``; names or shapes that disagree raise a ``ValueError``."""
    state = load_file(str(path))
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as err:
        raise ValueError(f"weights in {path} do not fit this model (config mismatch?):\n{err}") from err


def rng_state(generators: dict[str, torch.Generator]) -> dict[str, Any]:
    """Snapshot of torch's global RNGs and of the named generators."""
    state: dict[str, Any] = {"torch": torch.get_rng_state(), "generators": {}}
    if torch.cuda.is_available():
        state["cuda"] = torch.cuda.get_rng_state_all()
    for name, gen in generators.items():
        state["generators"][name] = gen.get_state()
    return state


def restore_rng_state(state: dict[str, Any], generators: dict[str, torch.Generator]) -> None:
    torch.set_rng_state(state["torch"])
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(state["cuda"])
    for name, gen in generators.items():
        if name not in state["generators"]:
            raise ValueError(f"checkpoint has no state for generator {name!r}")
        gen.set_state(state["generators"][name])


def save_checkpoint(
    folder: str | os.PathLike,
    step: int,
    model: nn.Module,
    optimizer: torch.optim.Optimizer | None = None,
    ema: EMA | None = None,
    generators: dict[str, torch.Generator] | None = None,
    meta: dict[str, Any] | None = None,
) -> Path:
    """Write ``folder/step_{step:08d}`` atomically and return its path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    final = folder / f"step_{step:08d}"
    tmp = folder / f".tmp-{final.name}-{uuid.uuid4().hex[:8]}"
    tmp.mkdir()
    try:
        save_weights(model.state_dict(), tmp / "model.safetensors")
        if ema is not None:
            save_weights(ema.state_dict(), tmp / "ema.safetensors")
        state = {
            "optimizer": optimizer.state_dict() if optimizer is not None else None,
            "rng": rng_state(generators or {}),
        }
        torch.save(state, tmp / "state.pt")
        (tmp / "meta.json").write_text(json.dumps({"step": step, **(meta or {})}, indent=1, default=str))
        if final.exists():  # re-saving the same step: drop the old copy first
            shutil.rmtree(final)
        os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return final


def load_checkpoint(
    path: str | os.PathLike,
    model: nn.Module,
    optimizer: torch.optim.Optimizer | None = None,
    ema: EMA | None = None,
    generators: dict[str, torch.Generator] | None = None,
) -> dict[str, Any]:
    """Restore what :func:`save_checkpoint` wrote into the given objects; returns the ``meta.json`` dict."""
    path = Path(path)
    if not (path / "meta.json").is_file():
        raise FileNotFoundError(f"{path} is not a complete checkpoint (no meta.json)")
    load_weights(model, path / "model.safetensors")
    if ema is not None:
        if not (path / "ema.safetensors").is_file():
            raise ValueError(f"{path} has no EMA weights but an EMA was given")
        ema.load_state_dict(load_file(str(path / "ema.safetensors")))
    state = torch.load(path / "state.pt", map_location="cpu", weights_only=True)
    if optimizer is not None:
        if state["optimizer"] is None:
            raise ValueError(f"{path} has no optimizer state but an optimizer was given")
        optimizer.load_state_dict(state["optimizer"])
    restore_rng_state(state["rng"], generators or {})
    return json.loads((path / "meta.json").read_text())


def list_checkpoints(folder: str | os.PathLike) -> list[Path]:
    """Complete checkpoints in ``folder``, oldest first (temporary folders are ignored)."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    found = [p for p in folder.iterdir() if p.is_dir() and _STEP_DIR.match(p.name) and (p / "meta.json").is_file()]
    return sorted(found, key=lambda p: p.name)


def latest_checkpoint(folder: str | os.PathLike) -> Path | None:
    found = list_checkpoints(folder)
    return found[-1] if found else None


def prune_checkpoints(folder: str | os.PathLike, keep: int) -> None:
    """Delete all but the ``keep`` newest checkpoints."""
    for old in list_checkpoints(folder)[:-keep] if keep > 0 else []:
        shutil.rmtree(old, ignore_errors=True)
