"""Read motion datasets stored in the HumanML3D on-disk layout (HumanML3D, KIT-ML, and the embedded set).

The layout::

    root/
      new_joint_vecs/<id>.npy   (T, 263) features (KIT-ML: 251)
      new_joints/<id>.npy       (T, J, 3) joint positions (optional here)
      texts/<id>.txt            one caption per line: "caption#tok/POS tok/POS ...#start#end"
      train.txt val.txt test.txt [train_val.txt all.txt]   one id per line
      Mean.npy Std.npy          normalisation statistics

Captions whose ``start#end`` is not ``0.0#0.0`` describe only part of a clip; the standard loaders cut
that part out as a separate entry (``motion[int(start*20):int(end*20)]``, the factor 20 is used for KIT too),
and so does :func:`load_split`.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..representation import Normalizer, Skeleton, skeleton_for_feature_dim

SPLITS = ("train", "val", "test", "train_val", "all")
# clip ids listed in the released HumanML3D split files (half carry the M prefix of a mirrored clip): what a
# full-scale schedule counted in epochs iterates over
HUMANML3D_SPLIT_SIZES = {"train": 23_384, "val": 1_460, "test": 4_384, "train_val": 24_844, "all": 29_228}


@dataclass(frozen=True)
class DatasetKind:
    """Length conventions of a dataset family (from the standard evaluation code)."""

    name: str
    feature_dim: int
    min_length: int  # clips shorter than this are dropped
    max_length: int  # clips of this length or longer are dropped (exclusive bound)
    max_motion_length: int = 196
    unit_length: int = 4  # lengths are floored to a multiple of this (the tokenizers' downsampling)


KINDS = {
    "humanml3d": DatasetKind("humanml3d", 263, min_length=40, max_length=200),
    "kit": DatasetKind("kit", 251, min_length=24, max_length=200),
}


@dataclass(frozen=True)
class Caption:
    text: str
    tokens: tuple[str, ...]  # "word/POS"
    start: float = 0.0  # seconds; 0.0 and 0.0 mean the whole clip
    end: float = 0.0


@dataclass
class MotionClip:
    """One entry of a split: features (T, D) and the captions that describe exactly these frames."""

    name: str
    features: np.ndarray = field(repr=False)
    captions: list[Caption]

    @property
    def length(self) -> int:
        return int(self.features.shape[0])


def parse_caption_line(line: str) -> Caption:
    """Parse ``caption#tok/POS tok/POS#start#end`` (start/end optional, NaN counts as 0)."""
    parts = line.rstrip("\n").split("#")
    if len(parts) < 2 or not parts[0].strip():
        raise ValueError(f"malformed caption line (expected 'caption#tokens#start#end'): {line!r}")
    text, tokens = parts[0].strip(), tuple(t for t in parts[1].split() if t)
    start = end = 0.0
    if len(parts) >= 4:
        start, end = (float(x) if x.strip() else 0.0 for x in parts[2:4])
        start, end = (0.0 if np.isnan(start) else start), (0.0 if np.isnan(end) else end)
    return Caption(text=text, tokens=tokens, start=start, end=end)


def format_caption_line(caption: Caption) -> str:
    return f"{caption.text}#{' '.join(caption.tokens)}#{caption.start}#{caption.end}"


def read_captions(path: str | os.PathLike) -> list[Caption]:
    with open(path, encoding="utf-8") as fh:
        return [parse_caption_line(line) for line in fh if line.strip()]


def read_split_ids(root: str | os.PathLike, split: str) -> list[str]:
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; expected one of {', '.join(SPLITS)}")
    path = Path(root) / f"{split}.txt"
    if not path.is_file():
        raise FileNotFoundError(f"split file {path} is missing")
    return [line.strip() for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def check_dataset(root: str | os.PathLike) -> list[str]:
    """Everything missing or malformed in a dataset folder, as human-readable lines (empty = fine)."""
    root = Path(root)
    if not root.exists():
        return [f"{root} does not exist"]
    if not root.is_dir():
        return [f"{root} is not a folder"]
    problems = [f"missing {name}" for name in ("new_joint_vecs", "texts") if not (root / name).is_dir()]
    problems += [f"missing {name}" for name in ("Mean.npy", "Std.npy") if not (root / name).is_file()]
    problems += [f"missing split file {s}.txt" for s in ("train", "val", "test") if not (root / f"{s}.txt").is_file()]
    if problems:
        return problems
    problems += _check_statistics(root)
    dims = set()
    for split in ("train", "val", "test"):
        for clip_id in read_split_ids(root, split):
            feat, text = root / "new_joint_vecs" / f"{clip_id}.npy", root / "texts" / f"{clip_id}.txt"
            if not feat.is_file():
                problems.append(f"{split}: {clip_id} has no new_joint_vecs/{clip_id}.npy")
            else:
                try:
                    values = np.load(feat, mmap_mode="r", allow_pickle=False)
                except (OSError, ValueError, EOFError) as err:
                    problems.append(f"{split}: new_joint_vecs/{clip_id}.npy cannot be read ({err})")
                    values = None
                if values is not None and values.ndim != 2:
                    problems.append(f"{split}: new_joint_vecs/{clip_id}.npy has shape {values.shape}, expected (T, D)")
                elif values is not None:
                    dims.add(values.shape[1])
                    if not np.isfinite(values).all():  # loading and training refuse such clips
                        problems.append(f"{split}: new_joint_vecs/{clip_id}.npy contains NaN or inf values")
            if not text.is_file():
                problems.append(f"{split}: {clip_id} has no texts/{clip_id}.txt")
            else:
                try:
                    if not read_captions(text):
                        problems.append(f"{split}: texts/{clip_id}.txt has no captions")
                except ValueError as err:
                    problems.append(f"{split}: texts/{clip_id}.txt: {err}")
    if len(dims) > 1:
        problems.append(f"clips disagree on the feature dimension: {sorted(dims)}")
    for dim in dims:
        if dim not in (k.feature_dim for k in KINDS.values()):
            problems.append(f"feature dimension {dim} is neither HumanML3D (263) nor KIT-ML (251)")
    try:
        stats_dim = np.load(root / "Mean.npy", allow_pickle=False).shape
    except (OSError, ValueError, EOFError):
        stats_dim = None  # already reported by _check_statistics
    if dims and stats_dim is not None and stats_dim != (next(iter(dims)),):
        problems.append(f"Mean.npy has shape {stats_dim}, features have {sorted(dims)} dims")
    return problems


def _check_statistics(root: Path) -> list[str]:
    """Mean.npy and Std.npy: readable 1-D arrays of equal size, finite, and Std strictly positive (models divide
    by it)."""
    problems, arrays = [], {}
    for name in ("Mean.npy", "Std.npy"):
        try:
            arrays[name] = np.load(root / name, allow_pickle=False)
        except (OSError, ValueError, EOFError) as err:
            problems.append(f"{name} cannot be read ({err})")
            continue
        values = arrays[name]
        if values.ndim != 1:
            problems.append(f"{name} has shape {values.shape}, expected (D,)")
        elif not np.isfinite(values).all():
            problems.append(f"{name} contains {int((~np.isfinite(values)).sum())} NaN or inf values")
    std = arrays.get("Std.npy")
    if std is not None and std.ndim == 1 and np.isfinite(std).all() and (std <= 0).any():
        problems.append(f"Std.npy has {int((std <= 0).sum())} zero or negative values (features are divided by it)")
    if len(arrays) == 2 and arrays["Mean.npy"].shape != arrays["Std.npy"].shape:
        problems.append(f"Mean.npy {arrays['Mean.npy'].shape} and Std.npy {arrays['Std.npy'].shape} differ in shape")
    return problems


def floor_to_unit(length: int, unit: int = 4) -> int:
    return (length // unit) * unit


def crop_to_unit(motion: np.ndarray, unit: int = 4, rng: np.random.Generator | None = None) -> np.ndarray:
    """Crop a clip to a multiple of ``unit`` frames; a random start offset when ``rng`` is given."""
    keep = floor_to_unit(len(motion), unit)
    start = int(rng.integers(0, len(motion) - keep + 1)) if rng is not None else 0
    return motion[start : start + keep]


def _shape_only(path: Path) -> np.ndarray:
    """A zero-strided stand-in of an ``.npy`` file's array with the file's shape, read from its header alone.

    A caption vocabulary reads thousands of them: the laptop training split's captions took 1.4 s with the files
    mapped (``mmap_mode``), 0.9 s this way.
    """
    with open(path, "rb") as f:
        version = np.lib.format.read_magic(f)
        read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, _, _ = read_header(f)
    return np.broadcast_to(np.zeros((), dtype=np.float32), shape)


class MotionDataset:
    """A dataset folder in the HumanML3D layout.

    >>> ds = MotionDataset("path/to/HumanML3D")      # doctest: +SKIP
    >>> test = ds.split("test")                       # list[MotionClip], raw (un-normalised) features
    >>> x = ds.normalizer.normalize(test[0].features)
    """

    def __init__(self, root: str | os.PathLike, kind: str | None = None):
        self.root = Path(root)
        if not self.root.is_dir():
            raise FileNotFoundError(f"dataset folder {self.root} does not exist")
        for name in ("new_joint_vecs", "texts"):
            if not (self.root / name).is_dir():
                raise FileNotFoundError(f"dataset folder {self.root} has no {name}/ subfolder")
        try:
            self.normalizer = Normalizer.load(self.root)
        except ValueError as err:  # unreadable, NaN or zero statistics
            raise ValueError(f"{self.root}: Mean.npy/Std.npy: {err}") from None
        inferred = "kit" if self.normalizer.dim == 251 else "humanml3d"
        if kind is not None and kind not in KINDS:
            raise ValueError(f"unknown dataset kind {kind!r}; expected one of {', '.join(KINDS)}")
        self.kind = KINDS[kind or inferred]
        if self.kind.feature_dim != self.normalizer.dim:
            raise ValueError(
                f"{self.root}: Mean.npy has {self.normalizer.dim} dims but kind {self.kind.name!r} "
                f"expects {self.kind.feature_dim}"
            )
        self._cache: dict[tuple, list[MotionClip]] = {}

    @property
    def skeleton(self) -> Skeleton:
        return skeleton_for_feature_dim(self.kind.feature_dim)

    @property
    def fps(self) -> float:
        return self.skeleton.fps

    @property
    def key(self) -> str:
        """A short name for this data and its normalisation, for cache keys of models trained on it."""
        digest = hashlib.sha1(self.normalizer.mean.tobytes() + self.normalizer.std.tobytes()).hexdigest()[:10]
        return f"{self.root.name}-{digest}"

    def normalized(self, split: str, **kwargs) -> list[np.ndarray]:
        """The split's features, z-normalised with the dataset's Mean/Std (what models train on)."""
        return [self.normalizer.normalize(c.features) for c in self.split(split, **kwargs)]

    def ids(self, split: str) -> list[str]:
        return read_split_ids(self.root, split)

    def split(self, split: str, filter_lengths: bool = True, limit: int | None = None) -> list[MotionClip]:
        """Clips of a split, with partial-caption segments cut out, filtered to the evaluation lengths."""
        key = (split, filter_lengths, limit)
        if key not in self._cache:
            self._cache[key] = self._load(split, filter_lengths, limit)
        return self._cache[key]

    def captions(self, split: str) -> list[list[Caption]]:
        """The captions of :meth:`split`'s clips, in the same order and with the same length filter, without
        reading the motions (only their lengths): what a vocabulary needs, at a fraction of the cost."""
        return [clip.captions for clip in self._load(split, True, None, read_motion=False)]

    def _load(self, split: str, filter_lengths: bool, limit: int | None, read_motion: bool = True) -> list[MotionClip]:
        kind, clips = self.kind, []
        for clip_id in self.ids(split):
            feat_path = self.root / "new_joint_vecs" / f"{clip_id}.npy"
            text_path = self.root / "texts" / f"{clip_id}.txt"
            if not feat_path.is_file() or not text_path.is_file():
                continue  # the public loaders skip ids without data the same way
            try:  # read_motion=False reads the header only: the shape is all the length filter needs
                motion = (
                    np.load(feat_path, allow_pickle=False).astype(np.float32) if read_motion else _shape_only(feat_path)
                )
            except (OSError, ValueError, EOFError) as err:
                raise ValueError(f"{feat_path} cannot be read ({err})") from None
            if motion.ndim != 2 or motion.shape[1] != kind.feature_dim:
                raise ValueError(f"{feat_path} has shape {motion.shape}, expected (T, {kind.feature_dim})")
            if read_motion and not np.isfinite(motion).all():
                raise ValueError(f"{feat_path} contains NaN or inf values")
            whole, parts = [], []
            for cap in read_captions(text_path):
                (whole if cap.start == 0.0 and cap.end == 0.0 else parts).append(cap)
            ok = lambda n: not filter_lengths or kind.min_length <= n < kind.max_length  # noqa: E731
            if whole and ok(len(motion)):
                clips.append(MotionClip(clip_id, motion, whole))
            for k, cap in enumerate(parts):
                segment = motion[int(cap.start * 20) : int(cap.end * 20)]
                if ok(len(segment)):
                    clips.append(MotionClip(f"{chr(65 + k % 26)}{k // 26 or ''}_{clip_id}", segment, [cap]))
            if limit is not None and len(clips) >= limit:
                return clips[:limit]
        if not clips:
            raise ValueError(f"split {split!r} of {self.root} has no clips within the length limits")
        return clips


def load_dataset(source: str | os.PathLike | None = None, profile: str | None = None, seed: int = 0) -> MotionDataset:
    """The book's dataset: the embedded one by default (generated and cached on first use), or a folder path."""
    if source is None or str(source) == "embedded":
        from .embedded import ensure_embedded

        return MotionDataset(ensure_embedded(profile=profile, seed=seed))
    return MotionDataset(source)
