"""Helpers shared by the exporters: one way to accept a motion, one way to write a file safely."""

from __future__ import annotations

import os
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..representation import (
    Skeleton,
    get_skeleton,
    joints_to_features,
    recover_from_ric,
    skeleton_for_feature_dim,
    skeleton_for_joint_count,
)


class MotionWarning(UserWarning):
    """Something about a motion that does not stop a conversion but changes what comes out (the CLI prints
    it as one ``warning:`` line)."""


def warn(message: str) -> None:
    warnings.warn(message, MotionWarning, stacklevel=3)


def bone_lengths(joints: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """Length of every bone per frame ``(T, J-1)``; column ``j-1`` is the bone ending at joint ``j``."""
    parents = list(skeleton.parents[1:])
    return np.linalg.norm(joints[:, 1:] - joints[:, parents], axis=-1)


def bone_stretch(joints: np.ndarray, skeleton: Skeleton) -> tuple[float, str, float, float]:
    """The bone whose length varies most within the motion: ``(max - min, "a -> b", min, max)`` in metres.

    Motions decoded from features (generated ones above all) need not keep their bones rigid; a BVH must.
    """
    lengths = bone_lengths(joints, skeleton) * skeleton.meters_per_unit  # (T, J-1)
    lo, hi = lengths.min(axis=0), lengths.max(axis=0)
    b = int(np.argmax(hi - lo))
    names = skeleton.joint_names
    return float(hi[b] - lo[b]), f"{names[skeleton.parents[b + 1]]} -> {names[b + 1]}", float(lo[b]), float(hi[b])


def checked_features(joints: np.ndarray, skeleton: Skeleton, name: str = "motion") -> np.ndarray:
    """``joints_to_features`` that refuses to return NaN: a degenerate pose (hips or shoulders on one point,
    so no facing direction) raises a ``ValueError`` naming the first bad frame."""
    with np.errstate(divide="ignore", invalid="ignore"):
        features = joints_to_features(joints, skeleton)
    bad = ~np.isfinite(features).all(axis=-1)
    if bad.any():
        frame = int(np.argmax(bad))
        raise ValueError(
            f"{name}: its features are NaN from frame {frame} on ({int(bad.sum())} of {len(bad)} "
            "frames): joints coincide (e.g. both hips or both shoulders on one point), so the body "
            "has no facing direction"
        )
    return features


def as_joints(motion, skeleton: str | Skeleton | None = None, name: str = "motion") -> tuple[np.ndarray, Skeleton]:
    """Joint positions ``(T, J, 3)`` (float64) and their skeleton from joints or HumanML3D features.

    ``motion`` is either joint positions ``(T, J, 3)`` or features ``(T, D)`` (263 for t2m, 251 for
    KIT), which are turned into positions with :func:`recover_from_ric`. A torch tensor is accepted too.
    """
    arr = motion.detach().cpu().numpy() if hasattr(motion, "detach") else np.asarray(motion)
    if arr.dtype == object or not np.issubdtype(arr.dtype, np.number):
        raise ValueError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    arr = arr.astype(np.float64)
    if arr.ndim in (2, 3) and arr.shape[0] < 1:
        raise ValueError(f"{name} has no frames, got shape {arr.shape}")
    if arr.ndim == 2:  # (T, D) features
        try:
            sk = skeleton_for_feature_dim(arr.shape[1])
        except ValueError:
            raise ValueError(
                f"{name} must be joints (T, J, 3) or features (T, 263|251), got shape {arr.shape}"
            ) from None
        if not np.isfinite(arr).all():
            raise ValueError(f"{name} contains NaN or inf values")
        arr = recover_from_ric(arr)  # (T, J, 3)
    elif arr.ndim == 3 and arr.shape[-1] == 3:
        try:
            sk = skeleton_for_joint_count(arr.shape[1])
        except ValueError:
            raise ValueError(f"{name} must have 22 (t2m) or 21 (kit) joints, got shape {arr.shape}") from None
    else:
        raise ValueError(f"{name} must be joints (T, J, 3) or features (T, 263|251), got shape {arr.shape}")
    if skeleton is not None:
        wanted = get_skeleton(skeleton)
        if wanted.n_joints != sk.n_joints:
            raise ValueError(f"{name} has {sk.n_joints} joints but skeleton {wanted.name!r} has {wanted.n_joints}")
        sk = wanted
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or inf values")
    return arr, sk


def _replace_atomically(path: str | os.PathLike, mode: str, write: Callable) -> Path:
    # Write into a temporary file in the target's folder (same file system), then rename it over the target.
    path = Path(path)
    if not path.parent.is_dir():
        raise ValueError(f"folder {str(path.parent)!r} of {str(path)!r} does not exist")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it owner-only; give it a normal file's permissions
        kwargs = {"encoding": "utf-8", "newline": "\n"} if "b" not in mode else {}
        with os.fdopen(fd, mode, **kwargs) as f:
            write(f)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)  # the only portable way to read it is to set it
    os.umask(mask)
    return mask


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder and ``os.replace``.

    A reader never sees half a file: either the old file (or none) or the complete new one.
    """
    return _replace_atomically(path, "w", lambda f: f.write(text))


def save_npy_atomic(path: str | os.PathLike, array: np.ndarray) -> Path:
    """``np.save`` through a temporary file and ``os.replace`` (see :func:`write_text_atomic`)."""
    return _replace_atomically(path, "wb", lambda f: np.save(f, array))
