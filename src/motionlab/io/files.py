"""Motion files by extension: what the CLI calls for ``--out x.bvh|x.html|x.npy`` and for conversions.

=========  ==================================================  =========================================
suffix     written by :func:`save_motion`                      read by :func:`load_joints`
=========  ==================================================  =========================================
``.bvh``   t2m rig, rotations from inverse kinematics           any BVH through a rig ("auto", "cmu", ...)
``.html``  standalone canvas animation (no network)           --
``.npy``   HumanML3D features ``(T-1, 263)``                   features ``(T, 263)`` or joints ``(T, 22, 3)``
=========  ==================================================  =========================================
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from .bvh_export import save_bvh
from .bvh_import import bvh_to_joints, fill_degenerate_joints
from .common import as_joints, checked_features, save_npy_atomic, warn
from .html import check_segments, save_html_animation
from .provenance import write_sidecar

MOTION_SUFFIXES = (".bvh", ".html", ".htm", ".npy")


def _suffix(path: Path, allowed: tuple[str, ...], role: str) -> str:
    suffix = path.suffix.lower()
    if suffix not in allowed:
        expected = ", ".join(allowed)
        raise ValueError(f"{role} {str(path)!r} has an unknown extension {suffix!r}; expected one of {expected}")
    return suffix


def save_motion(
    motion,
    path: str | os.PathLike,
    fps: float = 20.0,
    title: str | None = None,
    unit: str = "m",
    rotation_order: str = "ZYX",
    provenance: Mapping[str, str] | None = None,
    segments: Sequence[tuple[int, str]] | None = None,
) -> Path:
    """Write a motion (joints ``(T, 22, 3)`` in metres or features ``(T, 263)``) in the format of ``path``.

    ``.bvh``: :func:`~motionlab.io.bvh_export.save_bvh` (``unit``, ``rotation_order``); ``.html``/``.htm``:
    :func:`~motionlab.io.html.save_html_animation` (``title``, default the file name); ``.npy``: HumanML3D
    features ``(T-1, 263)`` (features are written as given, joints go through ``joints_to_features``).
    Every file is written through a temporary file and ``os.replace``. ``provenance`` (how the motion was made,
    :func:`~motionlab.io.provenance.motion_provenance`) goes into the HTML page, or into a sidecar
    ``<file>.json`` beside a ``.bvh``/``.npy`` (neither format has room for it that every reader skips).
    ``segments=[(start_frame, text), ...]`` (a motion of several actions, the first at frame 0): the HTML player
    names the action playing and marks each boundary; a ``.bvh``/``.npy`` gets them in its sidecar.
    """
    path = Path(path)
    suffix = _suffix(path, MOTION_SUFFIXES, "output")
    if segments is not None:
        segments = check_segments(segments, len(motion))  # before anything is written
    if suffix in (".html", ".htm"):
        title = path.stem if title is None else title
        return save_html_animation(motion, path, title=title, fps=fps, provenance=provenance, segments=segments)
    if suffix == ".bvh":
        written = save_bvh(motion, path, fps=fps, unit=unit, rotation_order=rotation_order)
    else:
        written = save_npy_atomic(path, _as_features(motion))
    if provenance or segments:
        sidecar = dict(provenance or {})
        if segments:
            sidecar["segments"] = [{"start_frame": start, "text": text} for start, text in segments]
        write_sidecar(written, sidecar)
    return written


def _as_features(motion) -> np.ndarray:
    arr = motion.detach().cpu().numpy() if hasattr(motion, "detach") else np.asarray(motion)
    joints, sk = as_joints(arr, name="motion")  # validates shape and finiteness
    if arr.ndim == 2:
        return arr.astype(np.float32)
    if joints.shape[0] < 2:
        raise ValueError("motion needs at least 2 frames to produce features")
    return checked_features(joints, sk).astype(np.float32)


def load_joints(
    path: str | os.PathLike,
    mapping: str | os.PathLike | Mapping[str, str] = "auto",
    scale: float | None = None,
    up: str | None = None,
    fps: float = 20.0,
    start: int = 0,
    end: int | None = None,
) -> np.ndarray:
    """Joint positions ``(T, 22, 3)`` in metres from a ``.bvh`` (through the rig ``mapping``: by default the one
    its joint names match) or ``.npy``.

    A ``.npy`` may hold features ``(T, 263)`` (recovered with ``recover_from_ric``) or joints
    ``(T, 22, 3)``; ``start``/``end`` crop its frames too. The BVH arguments are those of
    :func:`~motionlab.io.bvh_import.bvh_to_joints`.
    """
    path = Path(path)
    suffix = _suffix(path, (".bvh", ".npy"), "input")
    if not path.is_file():
        raise ValueError(f"input {str(path)!r} does not exist")
    if suffix == ".bvh":
        return bvh_to_joints(path, mapping=mapping, scale=scale, up=up, fps=fps, start=start, end=end)
    array = _read_npy(path)
    joints, sk = as_joints(array, name=f"array in {path.name}")
    if sk.name != "t2m":
        raise ValueError(f"{path.name}: only t2m motions (22 joints / 263 features) are supported, got {sk.name}")
    joints = joints[_crop(joints.shape[0], start, end)]
    if array.ndim == 3:  # joints as given: place joints that sit on their parent, as the BVH import does
        joints, moved = fill_degenerate_joints(joints, sk)
        if moved:
            warn(
                f"{path.name}: {', '.join(moved)} coincide with their parent joint in every frame; placed them "
                "halfway to the next joint of their chain"
            )
    return joints


def _read_npy(path: Path) -> np.ndarray:
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as err:  # EOFError: an empty file
        raise ValueError(f"{path} cannot be read as a .npy array ({err})") from None


def _crop(n: int, start: int, end: int | None) -> slice:
    end = n if end is None else end
    if not 0 <= start < end <= n:
        raise ValueError(f"crop [start, end) = [{start}, {end}) must lie within the {n} frames")
    return slice(start, end)


def convert_motion(
    src: str | os.PathLike,
    dst: str | os.PathLike,
    mapping: str | os.PathLike | Mapping[str, str] = "auto",
    scale: float | None = None,
    up: str | None = None,
    fps: float = 20.0,
    start: int = 0,
    end: int | None = None,
    title: str | None = None,
) -> Path:
    """Read ``src`` (``.bvh``/``.npy``) with :func:`load_joints` and write ``dst`` with :func:`save_motion`.

    E.g. ``convert_motion("131_02.bvh", "001417.npy", start=10, end=208)`` gives the 197 feature rows of
    the HumanML3D clip cut from that take. Features ``.npy`` -> ``.npy`` copies the (cropped) rows, so a
    round trip keeps every frame; joints -> features gives one row fewer than poses (HumanML3D's convention).
    """
    src, dst = Path(src), Path(dst)
    if _suffix(dst, MOTION_SUFFIXES, "output") == ".npy" and src.suffix.lower() == ".npy" and src.is_file():
        array = _read_npy(src)
        if array.ndim == 2:  # features -> features: copy the rows (a trip through joints would drop a frame)
            as_joints(array, "t2m", name=f"array in {src.name}")  # validates shape and values
            return save_npy_atomic(dst, array[_crop(array.shape[0], start, end)].astype(np.float32))
    joints = load_joints(src, mapping=mapping, scale=scale, up=up, fps=fps, start=start, end=end)
    return save_motion(joints, dst, fps=fps, title=title)
