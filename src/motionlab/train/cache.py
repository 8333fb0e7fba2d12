"""Train once, load ever after: trained models addressed by (name, profile, config hash).

    <cache>/models/<name>/<profile>/<hash>/        finished artefact: model.safetensors, config.json, result.json
    <cache>/models/<name>/<profile>/<hash>.work/   checkpoints of a run in progress (resumed if interrupted)

The hash covers the whole config (a dataclass) plus ``extra`` (e.g. which data it was trained on), so
any change trains a new model. The finished folder appears by one atomic rename after training, so a
crashed run can never be mistaken for a finished one.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from torch import nn

from ..paths import cache_path
from ..profiles import get_profile
from .checkpoint import load_weights, save_weights
from .device import get_device
from .distributed import barrier, current_context

BuildFn = Callable[[Any], nn.Module]
TrainFn = Callable[[nn.Module, Path], Any]


class NotCached(LookupError):
    """Raised inside :func:`cache_probe` where something would have to be trained or generated."""


_probing = 0


@contextmanager
def cache_probe() -> Iterator[None]:
    """Inside this block nothing is trained: the first model (or dataset) missing from the cache raises
    :class:`NotCached`. Running a recipe under it answers "is everything it needs cached?" with the recipe's
    own cache keys, so the answer can never disagree with what the recipe would load."""
    global _probing
    _probing += 1
    try:
        yield
    finally:
        _probing -= 1


def check_may_train(what: str) -> None:
    """Call before training or generating ``what``: raises :class:`NotCached` inside :func:`cache_probe`."""
    if _probing:
        raise NotCached(f"{what} is not in the cache")


def config_dict(config: Any) -> dict[str, Any]:
    """A JSON-ready dict of a dataclass config (tuples become lists)."""
    if not dataclasses.is_dataclass(config) or isinstance(config, type):
        raise ValueError(f"config must be a dataclass instance, got {type(config).__name__}")
    return json.loads(json.dumps(dataclasses.asdict(config), default=str))


def config_hash(config: Any, extra: dict[str, Any] | None = None) -> str:
    """12 hex digits of SHA-256 over the config's class name, its fields and ``extra``."""
    payload = {"type": type(config).__name__, "config": config_dict(config), "extra": extra or {}}
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def artefact_dir(name: str, config: Any, profile: str | None = None, extra: dict[str, Any] | None = None) -> Path:
    """Where the finished model for this (name, profile, config, extra) lives (it may not exist yet)."""
    if not name or "/" in name or "\\" in name or name.startswith("."):
        raise ValueError(f"name must be a plain folder name, got {name!r}")
    return cache_path("models", name, get_profile(profile), config_hash(config, extra))


def is_trained(name: str, config: Any, profile: str | None = None, extra: dict[str, Any] | None = None) -> bool:
    return (artefact_dir(name, config, profile, extra) / "model.safetensors").is_file()


def load_trained(
    name: str,
    config: Any,
    build_fn: BuildFn,
    profile: str | None = None,
    *,
    extra: dict[str, Any] | None = None,
    device: str | None = None,
) -> nn.Module:
    """Build the model from ``config`` and load its finished weights; ``FileNotFoundError`` if never trained."""
    folder = artefact_dir(name, config, profile, extra)
    if not (folder / "model.safetensors").is_file():
        raise FileNotFoundError(f"no trained {name!r} for profile {get_profile(profile)!r} at {folder}; train it first")
    saved = json.loads((folder / "config.json").read_text())
    if saved["config"] != config_dict(config):
        raise ValueError(f"{folder}/config.json does not match the requested config")
    model = build_fn(config)
    load_weights(model, folder / "model.safetensors")
    return model.to(get_device(device)).eval()


def load_result(name: str, config: Any, profile: str | None = None, extra: dict[str, Any] | None = None) -> Any:
    """What ``train_fn`` returned when the model was trained (e.g. its loss history)."""
    path = artefact_dir(name, config, profile, extra) / "result.json"
    if not path.is_file():
        raise FileNotFoundError(f"no result for {name!r} at {path}")
    return json.loads(path.read_text())


def train_or_load(
    name: str,
    config: Any,
    build_fn: BuildFn,
    train_fn: TrainFn,
    profile: str | None = None,
    *,
    extra: dict[str, Any] | None = None,
    device: str | None = None,
    retrain: bool = False,
) -> nn.Module:
    """Load the cached model for ``config`` or build it, train it, cache it, and return it (in eval mode).

    ``build_fn(config) -> model`` must be deterministic; ``train_fn(model, workdir)`` trains in place,
    may keep resumable checkpoints in ``workdir``, and may return JSON-able results (kept as result.json).
    """
    final = artefact_dir(name, config, profile, extra)
    if not retrain and (final / "model.safetensors").is_file():
        return load_trained(name, config, build_fn, profile, extra=extra, device=device)
    check_may_train(f"model {name!r} ({get_profile(profile)}, {final.name})")
    work = final.with_name(final.name + ".work")
    model = build_fn(config)
    result = train_fn(model, work)
    ctx = current_context()
    if ctx.is_main:  # under torchrun every rank trained the same weights; one writes them
        _publish(final, work, model, result, name, config, profile, extra)
    barrier(ctx)
    return model.to(get_device(device)).eval()


def _publish(final: Path, work: Path, model: nn.Module, result: Any, name: str, config: Any, profile, extra) -> None:
    """Write the finished artefact under a temporary name, rename it into place, drop the checkpoints."""
    tmp = final.with_name(f".{final.name}.tmp-{uuid.uuid4().hex[:8]}")
    tmp.mkdir(parents=True)
    try:
        save_weights(model.state_dict(), tmp / "model.safetensors")
        info = {"name": name, "profile": get_profile(profile), "hash": final.name, "type": type(config).__name__,
                "config": config_dict(config), "extra": extra or {}}  # fmt: skip
        (tmp / "config.json").write_text(json.dumps(info, indent=1, default=str))
        (tmp / "result.json").write_text(json.dumps(result, indent=1, default=str))
        if final.exists():  # retrain=True over an old artefact
            shutil.rmtree(final)
        os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    shutil.rmtree(work, ignore_errors=True)
