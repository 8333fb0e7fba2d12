"""Write the HumanML3D on-disk layout: one clip's files, the split files and a seeded split.

Shared by the two producers of such folders, the embedded generator (:mod:`motionlab.data.embedded`) and
the BVH importer (:mod:`motionlab.data.from_bvh`), so both follow the same conventions::

    new_joint_vecs/<id>.npy   float32 (T-1, 263)     features
    new_joints/<id>.npy       float32 (T-1, 22, 3)   recover_from_ric(features), as HumanML3D saves it
    texts/<id>.txt            "caption#tok/POS ...#start#end" lines, each ending in a newline
    <split>.txt               ids, one per line

Each file is written through a temporary file and ``os.replace``: a reader, or a resumed run, never finds
half a file. ``Mean.npy``/``Std.npy`` come from :meth:`motionlab.representation.Normalizer.save`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..io.common import save_npy_atomic, write_text_atomic

CLIP_FOLDERS = ("new_joint_vecs", "new_joints", "texts")
SPLIT_FRACTIONS = {"train": 0.80, "val": 0.05, "test": 0.15}


def make_layout(folder: str | os.PathLike) -> Path:
    """Create ``folder`` and its per-clip subfolders (existing ones are kept)."""
    folder = Path(folder)
    for sub in CLIP_FOLDERS:
        (folder / sub).mkdir(parents=True, exist_ok=True)
    return folder


def clip_files(folder: str | os.PathLike, clip_id: str) -> tuple[Path, Path, Path]:
    """The three files of a clip: features, joints, captions."""
    folder = Path(folder)
    return (
        folder / "new_joint_vecs" / f"{clip_id}.npy",
        folder / "new_joints" / f"{clip_id}.npy",
        folder / "texts" / f"{clip_id}.txt",
    )


def write_clip(
    folder: str | os.PathLike, clip_id: str, features: np.ndarray, joints: np.ndarray, caption_lines: Sequence[str]
) -> None:
    """Write one clip: features ``(T-1, D)`` and joints ``(T-1, J, 3)`` as float32, and its caption lines."""
    if not caption_lines:
        raise ValueError(f"clip {clip_id} needs at least one caption line")
    feat_path, joints_path, text_path = clip_files(folder, clip_id)
    save_npy_atomic(feat_path, np.asarray(features, dtype=np.float32))
    save_npy_atomic(joints_path, np.asarray(joints, dtype=np.float32))
    write_text_atomic(text_path, "\n".join(caption_lines) + "\n")


def write_split_files(folder: str | os.PathLike, splits: Mapping[str, Sequence[str]]) -> None:
    """``<name>.txt`` with one id per line for every split in ``splits``."""
    for name, ids in splits.items():
        write_text_atomic(Path(folder) / f"{name}.txt", "".join(f"{i}\n" for i in ids))


def stratified_split(
    groups: Mapping[str, Sequence[str]], rng: np.random.Generator, fractions: Mapping[str, float] = SPLIT_FRACTIONS
) -> dict[str, list[str]]:
    """Ids per split (``train``/``val``/``test``), about ``fractions`` within each group, each split sorted.

    A group of three or more ids puts at least one in ``val`` and one in ``test`` (so every group is seen in
    every split) and the rest in ``train``; a smaller group goes to ``train`` whole. Groups are visited in
    sorted order and shuffled with ``rng``, so the split is a pure function of the ids and the generator.
    """
    splits: dict[str, list[str]] = {"train": [], "val": [], "test": []}
    for group in sorted(groups):
        ids = rng.permutation(list(groups[group])).tolist()
        if len(ids) < 3:
            splits["train"] += ids
            continue
        n_val = max(1, round(fractions["val"] * len(ids)))
        n_test = max(1, round(fractions["test"] * len(ids)))
        splits["val"] += ids[:n_val]
        splits["test"] += ids[n_val : n_val + n_test]
        splits["train"] += ids[n_val + n_test :]
    return {name: sorted(ids) for name, ids in splits.items()}
