"""Carry a study's trained models from one time-limited job to the next, so that a point longer than one job resumes.

A job on a shared GPU often runs under limits: a scheduler's wall time, a preemptible (spot) instance, a machine that
starts bare and keeps nothing, and an output quota that returns files up to some size. A scale-study point whose
training outlasts one job would start from nothing in every job and never finish. So a run packs the part of its
model cache the remaining points need into an archive cut into parts no larger than the output limit
(:func:`pack_cache`, ``part_bytes``), the parts come back with the job's outputs, and the next job carries them in and
unpacks them (:func:`unpack_cache`) before it starts: a finished model is loaded instead of trained, and a model cut off
mid-way resumes from its last checkpoint (the trainer's ``.work`` folder).

What is carried (:func:`carried_folders`): every finished model whose config a pending point trains or loads (the
evaluator, a tokenizer two groups share, the models of a point cut off before its scoring), and the newest
checkpoint of every training in progress. Models only finished points used stay behind.
"""

from __future__ import annotations

import io
import json
import math
import tarfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

ARCHIVE = "scale-cache.tgz"  # its parts: scale-cache.tgz.00, .01, ...
PART_BYTES = 15 * 2**20  # the default part size: under a 16 MiB per-file output limit


def config_key(config: Any) -> str:
    """A config as one comparable string (the artefact's config.json stores tuples as lists)."""
    return json.dumps(json.loads(json.dumps(config, default=str)), sort_keys=True)


def carried_folders(cache_root: str | Path, pending_configs: Iterable[dict]) -> list[Path]:
    """The folders under ``cache_root/models`` the next run needs: finished artefacts whose config is one of
    ``pending_configs`` (the JSON configs of the models the pending points train or load) and every training in
    progress (``<hash>.work``)."""
    wanted = {config_key(c) for c in pending_configs}
    in_progress = sorted(work for work, _ in _in_progress(cache_root))
    return sorted(in_progress + [folder for folder, config in _finished(cache_root) if config in wanted])


def find_artefact(cache_root: str | Path, config: Any, precision: str | None = None) -> Path | None:
    """The finished artefact folder under ``cache_root/models`` trained with ``config`` (a JSON config), in
    ``precision`` where given, or None."""
    wanted = config_key(config)
    return next((folder for folder, found in _finished(cache_root, precision) if found == wanted), None)


def _finished(cache_root: str | Path, precision: str | None = None):
    """``(folder, normalised config)`` of every finished artefact under ``cache_root/models`` (trained in
    ``precision``, where given): not a training in progress (``.work``), a half-written one (``.<hash>.tmp-…``) or
    one moved aside (``.damaged-…``)."""
    for info_path in sorted((Path(cache_root) / "models").glob("*/*/*/config.json")):
        name = info_path.parent.name
        if not (name.startswith(".") or name.endswith(".work") or ".damaged-" in name):
            info = json.loads(info_path.read_text())
            if _in_precision(info, precision):
                yield info_path.parent, config_key(info.get("config"))


def _in_progress(cache_root: str | Path):
    """``(.work folder, newest checkpoint's step)`` of every training in progress under ``cache_root``."""
    for work in (Path(cache_root) / "models").glob("*/*/*.work"):
        newest = _newest_checkpoint(work)
        if newest is not None:
            yield work, int(newest.name.removeprefix("step_"))


def cached_progress(cache_root: str | Path, precision: str | None = None) -> dict[str, float]:
    """How far the cache under ``cache_root`` has trained each config (in ``precision``, where given: a model trained
    in another is another artefact): ``{config_key(config): steps}``, the newest checkpoint's step for a training in
    progress (one whose ``.work`` folder says what it trains) and ``inf`` for a finished model. A plan subtracts
    these steps from what a point still has to train."""
    progress: dict[str, float] = {}
    for work, step in _in_progress(cache_root):
        if (work / "config.json").is_file():
            info = json.loads((work / "config.json").read_text())
            if _in_precision(info, precision):
                progress[config_key(info.get("config"))] = step
    progress.update((config, math.inf) for _, config in _finished(cache_root, precision))
    return progress


def _in_precision(info: dict, precision: str | None) -> bool:
    return precision is None or (info.get("extra") or {}).get("precision", precision) == precision


def _newest_checkpoint(work: Path) -> Path | None:
    steps = sorted(p for p in work.glob("step_*") if p.is_dir())
    return steps[-1] if steps else None


def pack_cache(
    cache_root: str | Path,
    folders: Iterable[Path],
    out_dir: str | Path,
    max_parts: int = 4,
    part_bytes: int | None = None,
) -> tuple[list[Path], str]:
    """Write ``folders`` (under ``cache_root``; of a ``.work`` folder only its newest checkpoint) to ``out_dir`` as
    :data:`ARCHIVE` parts of at most ``part_bytes`` (default :data:`PART_BYTES`), replacing any parts there. Returns
    the parts and one line for the log; writes nothing (and says why) where the archive would need more than
    ``max_parts`` parts."""
    part_bytes = PART_BYTES if part_bytes is None else part_bytes
    if isinstance(part_bytes, bool) or not isinstance(part_bytes, int) or part_bytes < 1:
        raise ValueError(f"part_bytes must be a positive int, got {part_bytes!r}")
    cache_root, out_dir = Path(cache_root), Path(out_dir)
    folders = list(folders)
    for old in out_dir.glob(f"{ARCHIVE}.*"):
        old.unlink()
    if not folders:
        return [], "nothing to carry: no model the remaining points need is in the cache"
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as archive:
        for folder in folders:
            sources = [folder]
            if folder.name.endswith(".work"):  # its newest checkpoint and what it trains
                sources = [_newest_checkpoint(folder), *[p for p in [folder / "config.json"] if p.is_file()]]
            for source in sources:
                archive.add(source, arcname=str(source.relative_to(cache_root)))
    data = buffer.getvalue()
    parts = -(-len(data) // part_bytes)
    mib = len(data) / 2**20
    if parts > max_parts:
        return [], f"not carried: {len(folders)} model folder(s) make {mib:.1f} MiB, over {max_parts} parts"
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for k in range(parts):
        path = out_dir / f"{ARCHIVE}.{k:02d}"
        path.write_bytes(data[k * part_bytes : (k + 1) * part_bytes])
        written.append(path)
    names = ", ".join(str(f.relative_to(cache_root / "models")) for f in folders)
    return written, f"carried {len(folders)} model folder(s) in {parts} part(s), {mib:.1f} MiB: {names}"


def unpack_cache(in_dir: str | Path, cache_root: str | Path) -> list[str]:
    """Unpack the :data:`ARCHIVE` parts in ``in_dir`` into ``cache_root``; returns the top folders unpacked ([] where
    there are no parts). A finished artefact already in the cache is kept as it is."""
    parts = sorted(Path(in_dir).glob(f"{ARCHIVE}.[0-9][0-9]"))
    if not parts:
        return []
    cache_root = Path(cache_root)
    data = b"".join(p.read_bytes() for p in parts)
    unpacked = set()
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as archive:
        members = []
        for member in archive.getmembers():
            top = Path(*Path(member.name).parts[:4])  # models/<name>/<profile>/<hash>[.work]
            if top.parts[0] != "models" or len(top.parts) < 4:
                raise ValueError(f"{parts[0].name}: {member.name} is not a model folder")
            if not top.name.endswith(".work") and (cache_root / top / "model.safetensors").is_file():
                continue
            members.append(member)
            unpacked.add(str(top))
        archive.extractall(cache_root, members=members, filter="data")
    return sorted(unpacked)


__all__ = [
    "ARCHIVE",
    "PART_BYTES",
    "cached_progress",
    "carried_folders",
    "config_key",
    "find_artefact",
    "pack_cache",
    "unpack_cache",
]
