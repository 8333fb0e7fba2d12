"""Write the embedded dataset in HumanML3D's on-disk layout, atomically, and cache it.

Layout (identical to the real dataset, so one loader reads both)::

    new_joint_vecs/E000123.npy   float32 (T-1, 263)  joints_to_features(joints)
    new_joints/E000123.npy       float32 (T-1, 22, 3) recover_from_ric(features, 22), as HumanML3D saves it
    texts/E000123.txt            "caption#tok/POS ...#0.0#0.0", one caption per line
    train.txt val.txt test.txt all.txt   ids, ~80/5/15, stratified by (first) action family
    Mean.npy Std.npy             Normalizer.fit(train features): mean and group-averaged std
    meta.json                    generator version, seed, and per clip: family, parameters, length

The folder is assembled next to the target under a hidden temporary name and moved into place with one
``os.replace``: an interrupted run leaves nothing at the target path.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_all_start_methods, get_context
from pathlib import Path

import numpy as np
import torch
from tqdm.auto import tqdm

from motionlab.paths import cache_path
from motionlab.representation import Normalizer, joints_to_features, recover_from_ric
from motionlab.sizes import run_sizes
from motionlab.train.cache import check_may_train
from motionlab.train.progress import bars_enabled

from ..writing import SPLIT_FRACTIONS, make_layout, stratified_split, write_clip, write_split_files
from .captions import caption_line
from .generator import FAMILIES, VERSION, generate_clip

CHAIN_FRACTION = 0.15  # share of clips that chain two actions ("walks forward and then waves")


def clip_id(index: int) -> str:
    return f"E{index:06d}"


def _rng(seed: int, *key: int) -> np.random.Generator:
    """An independent generator for ``(seed, key...)``: the same stream whatever order clips are built in."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def plan_families(n_clips: int, seed: int) -> list[str]:
    """The family spec of every clip: balanced over :data:`FAMILIES`, ~15 % chained with a second action."""
    rng = _rng(seed, 0)
    names = list(FAMILIES)
    first = np.resize(rng.permutation(len(names)), n_clips)  # every family about equally often
    first = first[rng.permutation(n_clips)]
    specs = []
    for i in first:
        if rng.random() < CHAIN_FRACTION:
            other = rng.choice([j for j in range(len(names)) if j != i])
            specs.append(f"{names[i]}+{names[other]}")
        else:
            specs.append(names[i])
    return specs


def stratified_splits(specs: list[str], seed: int) -> dict[str, list[str]]:
    """Ids per split, ~80/5/15 within each first family, with at least one clip of each family per split."""
    by_family: dict[str, list[str]] = {}
    for i, spec in enumerate(specs):
        by_family.setdefault(spec.split("+")[0], []).append(clip_id(i))
    return stratified_split(by_family, _rng(seed, 2), SPLIT_FRACTIONS)


def build_clip(seed: int, index: int, spec: str) -> tuple[np.ndarray, np.ndarray, list[str], dict]:
    """Features ``(T-1, 263)``, joints ``(T-1, 22, 3)`` (both float32), caption lines and meta of one clip."""
    clip = generate_clip(spec, _rng(seed, 1, index), cuts=True)
    # The clip is already on the target skeleton, so retargeting would change nothing but the run time.
    features = joints_to_features(clip.joints, "t2m", retarget_to_target=False).astype(np.float32)
    joints = recover_from_ric(features, 22).astype(np.float32)
    meta = {
        "family": clip.family,
        "families": list(clip.families),
        "single_action": clip.single_action,
        "params": clip.params,
        "n_frames": int(features.shape[0]),
    }
    return features, joints, [caption_line(c) for c in clip.captions], meta


def _build_star(args: tuple[int, int, str]):
    return build_clip(*args)


def _init_worker() -> None:
    torch.set_num_threads(1)  # two workers on two cores: no oversubscription


def _build_all(seed: int, specs: list[str], workers: int) -> Iterator[tuple]:
    jobs = [(seed, i, spec) for i, spec in enumerate(specs)]
    if workers <= 1:
        threads = torch.get_num_threads()
        torch.set_num_threads(1)  # tiny tensors: threading costs more than it saves
        try:
            yield from map(_build_star, jobs)
        finally:
            torch.set_num_threads(threads)
        return
    # fork where the platform has it: spawn would re-run an unguarded __main__ script in every worker.
    # Workers set torch to one thread before any work, which keeps OpenMP safe after the fork.
    method = "fork" if "fork" in get_all_start_methods() else "spawn"
    with ProcessPoolExecutor(workers, mp_context=get_context(method), initializer=_init_worker) as pool:
        yield from pool.map(_build_star, jobs, chunksize=16)


def _write_into(folder: Path, n_clips: int, seed: int, progress: bool, workers: int) -> None:
    specs = plan_families(n_clips, seed)
    splits = stratified_splits(specs, seed)
    make_layout(folder)
    train = set(splits["train"])
    train_features, clips_meta = [], {}
    bar = tqdm(total=n_clips, desc="embedded dataset", unit="clip", disable=not (progress and bars_enabled()))
    for index, (features, joints, lines, meta) in enumerate(_build_all(seed, specs, workers)):
        cid = clip_id(index)
        write_clip(folder, cid, features, joints, lines)
        if cid in train:
            train_features.append(features)
        clips_meta[cid] = meta
        bar.update()
    bar.close()
    write_split_files(folder, {**splits, "all": sorted(clips_meta)})
    split_of = {cid: name for name, ids in splits.items() for cid in ids}
    for cid in clips_meta:
        clips_meta[cid]["split"] = split_of[cid]
    Normalizer.fit(train_features).save(folder)
    meta = {
        "generator": "motionlab.data.embedded",
        "version": VERSION,
        "seed": seed,
        "n_clips": n_clips,
        "skeleton": "t2m",
        "fps": 20,
        "families": list(FAMILIES),
        "splits": {name: len(ids) for name, ids in splits.items()},
        "clips": clips_meta,
    }
    (folder / "meta.json").write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n", encoding="utf-8")


def write_embedded_dataset(
    root: str | os.PathLike,
    n_clips: int,
    seed: int = 0,
    progress: bool = True,
    workers: int | None = None,
    overwrite: bool = False,
) -> Path:
    """Generate ``n_clips`` clips from ``seed`` and write them to ``root`` in the HumanML3D layout.

    ``workers`` processes build clips in parallel (default: 2 for 256 clips or more, else 1); the output
    is byte-identical for any number of workers. An existing ``root`` is replaced only if ``overwrite``.
    """
    root = Path(root)
    minimum = 3 * len(FAMILIES)
    if int(n_clips) != n_clips or n_clips < minimum:
        raise ValueError(
            f"n_clips must be an integer >= {minimum} (3 per family, so each family can appear in "
            f"train, val and test), got {n_clips!r}"
        )
    if int(seed) != seed or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if workers is None:
        workers = min(2, os.cpu_count() or 1) if n_clips >= 256 else 1
    if root.exists() and any(root.iterdir()) and not overwrite:
        raise FileExistsError(f"{root} already exists and is not empty; pass overwrite=True to replace it")
    root.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{root.name}.partial-", dir=root.parent))
    try:
        _write_into(tmp, int(n_clips), int(seed), progress, workers)
        if root.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{root.name}.old-", dir=root.parent))
            os.replace(root, old / "previous")
            os.replace(tmp, root)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, root)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return root


def embedded_path(profile: str | None = None, seed: int = 0) -> Path:
    """Where :func:`ensure_embedded` keeps the dataset of a profile and seed (it may not exist yet)."""
    n = run_sizes(profile).embedded_clips
    return cache_path("data", f"embedded-v{VERSION}-n{n}-s{seed}")


def _npy_size(shape: tuple[int, ...]) -> int:
    """Bytes of a float32 ``.npy`` of ``shape`` as ``np.save`` writes it (format 1.0 header + data)."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f4", "fortran_order": False, "shape": shape})
    return len(header.getvalue()) + 4 * int(np.prod(shape))


def embedded_damage(root: str | os.PathLike) -> str | None:
    """What is wrong with a cached embedded dataset (a missing or truncated file), or None when intact.

    Cheap enough for every start (file sizes only): each clip's two arrays must have exactly the size its
    ``meta.json`` length implies, its caption file must exist, and Mean/Std must be whole.
    """
    root = Path(root)
    try:
        meta = json.loads((root / "meta.json").read_text(encoding="utf-8"))
        clips = meta["clips"]
    except (OSError, ValueError, KeyError, TypeError) as err:
        return f"{root / 'meta.json'} cannot be read ({err})"
    expected = {"Mean.npy": _npy_size((263,)), "Std.npy": _npy_size((263,))}
    for cid, info in clips.items():
        n = int(info["n_frames"])
        expected[f"new_joint_vecs/{cid}.npy"] = _npy_size((n, 263))
        expected[f"new_joints/{cid}.npy"] = _npy_size((n, 22, 3))
        expected[f"texts/{cid}.txt"] = -1  # any non-empty size
    for name, size in expected.items():
        try:
            actual = os.stat(root / name).st_size
        except OSError:
            return f"{root / name} is missing"
        if actual != size and not (size < 0 and actual > 0):
            return f"{root / name} has {actual} bytes, expected {size if size >= 0 else 'some'} (truncated?)"
    return None


def ensure_embedded(profile: str | None = None, seed: int = 0, progress: bool = True) -> Path:
    """The embedded dataset folder for ``profile`` (smoke / laptop / full), generated on first use.

    A cached copy with a missing or truncated file (:func:`embedded_damage`) is moved aside to
    ``<name>.damaged-<time>`` and generated again (the generator is deterministic).
    """
    path = embedded_path(profile, seed)
    if (path / "meta.json").is_file():
        damage = embedded_damage(path)
        if damage is None:
            return path
        moved = path.with_name(f"{path.name}.damaged-{time.strftime('%Y%m%d-%H%M%S')}")
        os.replace(path, moved)
        print(
            f"warning: the cached embedded dataset is damaged: {damage}; moved it to {moved.name} and "
            "generating it again",
            file=sys.stderr,
        )
    check_may_train(f"the embedded dataset {path.name}")
    n = run_sizes(profile).embedded_clips
    try:
        return write_embedded_dataset(path, n, seed=seed, progress=progress, overwrite=path.exists())
    except OSError:
        if (path / "meta.json").is_file():  # another process finished the same dataset first
            return path
        raise
