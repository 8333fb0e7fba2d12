"""Train once, load ever after: trained models addressed by (name, profile, config hash).

    <cache>/models/<name>/<profile>/<hash>/        finished artefact: model.safetensors, config.json, result.json
    <cache>/models/<name>/<profile>/<hash>.work/   checkpoints of a run in progress (resumed if interrupted) and
                                                   its config.json (what it trains, before it is finished)

The hash covers the whole config (a dataclass) plus ``extra`` (e.g. which data it was trained on), so
any change trains a new model. The finished folder appears by one atomic rename after training, so a
crashed run can never be mistaken for a finished one.

A finished artefact records the SHA-256 of its weights in ``config.json`` (``"sha256"``), checked on every
load: a truncated, garbage or bit-flipped ``model.safetensors`` (or an unreadable ``config.json``) raises
:class:`DamagedArtefactError` naming the file. :func:`train_or_load` then moves the folder aside, to
``<hash>.damaged-<time>``, and trains again; :func:`load_trained` (loading only) stops with that error.
Artefacts written before checksums existed are accepted once if their weights load and are all finite;
their checksum is recorded then, so later loads verify them too.

A finished artefact also keeps the trainer's sittings (``"sittings"`` in ``config.json``, :func:`training_sittings`):
how many steps each process that trained it ran, in how many seconds, on what hardware.

A command that first probes its plan (:func:`cache_probe`, to announce what it would train) and then runs it
wraps both in :func:`reuse_probed_models`: each model the probe loaded is handed to the command's own load of
the same artefact instead of being read and verified a second time.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import sys
import time
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import torch
from torch import nn

from ..paths import cache_path
from ..precision import resolve_precision
from ..profiles import get_profile
from .checkpoint import latest_checkpoint, load_weights, save_weights
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


# (artefact folder, device) -> (model loaded by a probe, stamp of its weights file); None: not collecting
_probed: dict[tuple[Path, str], tuple[nn.Module, tuple[int, int, int]]] | None = None


@contextmanager
def reuse_probed_models() -> Iterator[None]:
    """Inside this block a model that a :func:`cache_probe` loads is kept, and the first :func:`train_or_load` of
    the same artefact on the same device outside the probe takes it (once) instead of loading it again.

    Probing a plan runs its recipes, so it loads every cached model a command then loads itself; this makes
    that second load free. A model is handed over only if its weights file is unchanged since the probe read
    it; models no one takes are dropped when the block ends.
    """
    global _probed
    outermost = _probed is None
    if outermost:
        _probed = {}
    try:
        yield
    finally:
        if outermost:
            _probed = None


def _stamp(weights: Path) -> tuple[int, int, int]:
    """Identifies one version of a file: a rewrite or replacement changes it."""
    st = weights.stat()
    return st.st_mtime_ns, st.st_size, st.st_ino


def _keep_probed(folder: Path, device: str | None, model: nn.Module) -> None:
    if _probing and _probed is not None:
        _probed[(folder, str(get_device(device)))] = (model, _stamp(folder / "model.safetensors"))


def _take_probed(folder: Path, device: str | None) -> nn.Module | None:
    """The model a probe loaded from ``folder`` for ``device``, if any and its weights are unchanged (else None)."""
    if _probing or not _probed:
        return None
    kept = _probed.pop((folder, str(get_device(device))), None)
    if kept is None:
        return None
    model, stamp = kept
    try:
        return model if _stamp(folder / "model.safetensors") == stamp else None
    except OSError:
        return None


def check_may_train(what: str) -> None:
    """Call before training or generating ``what``: raises :class:`NotCached` inside :func:`cache_probe`, or
    when ``$MOTIONLAB_NO_TRAIN`` is set (``motionlab book execute`` sets it: chapters must only load)."""
    if _probing:
        raise NotCached(f"{what} is not in the cache")
    if os.environ.get("MOTIONLAB_NO_TRAIN"):
        raise NotCached(
            f"{what} is not in the cache and $MOTIONLAB_NO_TRAIN is set: train it first "
            "(`motionlab train book` trains every model the book's chapters load)"
        )


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


def artefact_dir(
    name: str,
    config: Any,
    profile: str | None = None,
    extra: dict[str, Any] | None = None,
    device: str | torch.device | None = None,
    precision: str | None = None,
) -> Path:
    """Where the finished model for this (name, profile, config, extra, precision) lives (it may not exist yet).

    ``precision`` is what the model trains in: the run's (:mod:`motionlab.precision`, resolved for ``device``)
    unless the model fixes its own. A model trained in bf16 is another artefact than the same config in fp32.
    """
    if not name or "/" in name or "\\" in name or name.startswith("."):
        raise ValueError(f"name must be a plain folder name, got {name!r}")
    return cache_path("models", name, get_profile(profile), artefact_key(config, extra, device, precision))


def artefact_key(
    config: Any,
    extra: dict[str, Any] | None = None,
    device: str | torch.device | None = None,
    precision: str | None = None,
) -> str:
    """The folder name of a trained model: :func:`config_hash` of its config, ``extra`` and its precision."""
    return config_hash(config, _keyed(extra, device, precision))


def _keyed(extra: dict[str, Any] | None, device: str | torch.device | None, precision: str | None) -> dict[str, Any]:
    """``extra`` plus the precision the model trains in: what the cache key covers besides the config."""
    return {**(extra or {}), "precision": resolve_precision(precision, get_device(device))}


class DamagedArtefactError(ValueError):
    """A cached artefact whose files are damaged (checksum mismatch, unreadable or non-finite weights)."""

    def __init__(self, folder: Path, message: str):
        super().__init__(message)
        self.folder = folder


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 hex digest of a file, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def is_trained(
    name: str,
    config: Any,
    profile: str | None = None,
    extra: dict[str, Any] | None = None,
    device: str | torch.device | None = None,
    precision: str | None = None,
) -> bool:
    return (artefact_dir(name, config, profile, extra, device, precision) / "model.safetensors").is_file()


def load_trained(
    name: str,
    config: Any,
    build_fn: BuildFn,
    profile: str | None = None,
    *,
    extra: dict[str, Any] | None = None,
    device: str | None = None,
    precision: str | None = None,
) -> nn.Module:
    """Build the model from ``config`` and load its finished weights; ``FileNotFoundError`` if never trained.

    Damaged files raise :class:`DamagedArtefactError` (a ``ValueError``) naming the file; the folder is left
    in place (:func:`train_or_load` moves it aside and retrains).
    """
    folder = artefact_dir(name, config, profile, extra, device, precision)
    if not (folder / "model.safetensors").is_file():
        raise FileNotFoundError(f"no trained {name!r} for profile {get_profile(profile)!r} at {folder}; train it first")
    model = build_fn(config)
    _load_verified(model, folder, name, config_dict(config))
    return model.to(get_device(device)).eval()


def _damaged(folder: Path, name: str, what: str) -> DamagedArtefactError:
    return DamagedArtefactError(
        folder,
        f"the cached {name!r} model is damaged: {what}; the next command that "
        f"trains it moves {folder.name} aside and trains it again",
    )


def _load_verified(model: nn.Module, folder: Path, name: str, wanted: dict[str, Any]) -> None:
    """Load ``folder/model.safetensors`` into ``model`` after checking it against the recorded checksum."""
    weights, info_path = folder / "model.safetensors", folder / "config.json"
    try:
        info = json.loads(info_path.read_text())
        if not isinstance(info, dict) or "config" not in info:
            raise ValueError("no 'config' entry")
    except (OSError, ValueError) as err:  # json.JSONDecodeError and UnicodeDecodeError are ValueErrors
        raise _damaged(folder, name, f"{info_path} cannot be read ({err})") from None
    if info["config"] != wanted:
        raise ValueError(f"{info_path} does not match the requested config")
    recorded = info.get("sha256")
    if recorded is not None and file_sha256(weights) != recorded:
        raise _damaged(folder, name, f"{weights} does not match its recorded checksum (truncated or altered)")
    try:
        load_weights(model, weights)
    except ValueError:
        if recorded is None:  # a legacy artefact whose weights do not fit: damaged, not a config mismatch
            raise _damaged(folder, name, f"{weights} does not hold this model's weights") from None
        raise
    except Exception as err:  # safetensors' own error type for a truncated or garbage file
        raise _damaged(folder, name, f"{weights} cannot be read ({type(err).__name__}: {err})") from None
    if recorded is None:  # written before checksums existed: accept finite weights once, then record them
        if not all(torch.isfinite(t).all() for t in model.state_dict().values() if t.is_floating_point()):
            raise _damaged(folder, name, f"{weights} holds NaN or inf values")
        try:
            info["sha256"] = file_sha256(weights)
            _write_json_atomic(info_path, info)
        except OSError:
            pass  # a read-only cache still loads; it just stays unverified


def _write_json_atomic(path: Path, data: Any) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{uuid.uuid4().hex[:8]}")
    try:
        tmp.write_text(json.dumps(data, indent=1, default=str))
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def move_aside(folder: Path) -> Path:
    """Rename a damaged artefact folder to ``<name>.damaged-<YYYYmmdd-HHMMSS>`` (kept for inspection)."""
    target = folder.with_name(f"{folder.name}.damaged-{time.strftime('%Y%m%d-%H%M%S')}")
    while target.exists():
        target = target.with_name(target.name + "x")
    os.replace(folder, target)
    return target


def load_result(
    name: str,
    config: Any,
    profile: str | None = None,
    extra: dict[str, Any] | None = None,
    device: str | torch.device | None = None,
    precision: str | None = None,
) -> Any:
    """What ``train_fn`` returned when the model was trained (e.g. its loss history)."""
    path = artefact_dir(name, config, profile, extra, device, precision) / "result.json"
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
    precision: str | None = None,
) -> nn.Module:
    """Load the cached model for ``config`` or build it, train it, cache it, and return it (in eval mode).

    ``build_fn(config) -> model`` must be deterministic; ``train_fn(model, workdir)`` trains in place,
    may keep resumable checkpoints in ``workdir``, and may return JSON-able results (kept as result.json).
    ``precision``: what the model trains in (part of the key), None for the run's; ``train_fn`` must train in it.
    """
    final = artefact_dir(name, config, profile, extra, device, precision)
    probed = None if retrain else _take_probed(final, device)
    if probed is not None:
        return probed
    if not retrain and (final / "model.safetensors").is_file():
        try:
            model = load_trained(name, config, build_fn, profile, extra=extra, device=device, precision=precision)
            _keep_probed(final, device, model)
            return model
        except DamagedArtefactError as err:
            if current_context().is_main:  # under torchrun one rank moves it; all of them retrain
                moved = move_aside(final) if final.exists() else final
                print(
                    f"warning: {str(err).split(';')[0]}; moved it to {moved.name} and training it again",
                    file=sys.stderr,
                )
            barrier(current_context())
    check_may_train(f"model {name!r} ({get_profile(profile)}, {final.name})")
    work = final.with_name(final.name + ".work")
    info = _artefact_info(final, name, config, profile, _keyed(extra, device, precision))
    if current_context().is_main:  # says what a training in progress trains (a plan counts its steps done)
        work.mkdir(parents=True, exist_ok=True)
        _write_json_atomic(work / "config.json", info)
    model = build_fn(config)
    result = train_fn(model, work)
    ctx = current_context()
    if ctx.is_main:  # under torchrun every rank trained the same weights; one writes them
        _publish(final, work, model, result, info)
    barrier(ctx)
    return model.to(get_device(device)).eval()


def _checkpointed_sittings(work: Path) -> list[dict[str, Any]]:
    """The sittings the newest checkpoint in ``work`` lists ([] where training kept no checkpoint)."""
    newest = latest_checkpoint(work)
    if newest is None:
        return []
    return json.loads((newest / "meta.json").read_text()).get("sittings", [])


def training_sittings(folder: str | os.PathLike) -> list[dict[str, Any]]:
    """The sittings that trained the finished artefact in ``folder``, oldest first: ``{"steps": [first, last],
    "seconds": ..., "device": "cpu" | "cuda", "name": ..., ...}`` each (seconds None where a checkpoint written
    before sittings were kept resumed it). [] for an artefact trained without checkpoints or before they existed."""
    info = json.loads((Path(folder) / "config.json").read_text())
    return list(info.get("sittings", []))


def _artefact_info(final: Path, name: str, config: Any, profile, extra: dict[str, Any]) -> dict[str, Any]:
    """What ``config.json`` says of an artefact (a finished one adds its checksum and sittings)."""
    return {
        "name": name,
        "profile": get_profile(profile),
        "hash": final.name,
        "type": type(config).__name__,
        "config": config_dict(config),
        "extra": extra,
    }


def _publish(final: Path, work: Path, model: nn.Module, result: Any, info: dict[str, Any]) -> None:
    """Write the finished artefact under a temporary name, rename it into place, drop the checkpoints."""
    tmp = final.with_name(f".{final.name}.tmp-{uuid.uuid4().hex[:8]}")
    tmp.mkdir(parents=True)
    try:
        save_weights(model.state_dict(), tmp / "model.safetensors")
        info = {**info, "sha256": file_sha256(tmp / "model.safetensors")}
        if sittings := _checkpointed_sittings(work):
            info["sittings"] = sittings
        (tmp / "config.json").write_text(json.dumps(info, indent=1, default=str))
        (tmp / "result.json").write_text(json.dumps(result, indent=1, default=str))
        if final.exists():  # retrain=True over an old artefact
            shutil.rmtree(final)
        os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    shutil.rmtree(work, ignore_errors=True)
