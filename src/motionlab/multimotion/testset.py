"""The multi-action test set (M2D2M §5.2 and appendix B), built from a dataset's test split.

M2D2M keeps the test captions that name a single action verb and draws N of them (no overlap) per
instance; each action keeps the length of the motion it came from. Here:

* **pool**: clips of the split that show one action and last at least :data:`MIN_ACTION_FRAMES`. The embedded
  dataset records this in its ``meta.json`` (``single_action`` and ``family`` per clip); for a folder without it
  (real HumanML3D) a clip counts as single-action when one of its captions has exactly one ``VERB`` tag, and that
  verb's lemma is its family.
* **instance**: N distinct families (or, with ``distinct_families=False``, just N distinct clips), one clip
  of each family and one of its captions, drawn uniformly with a seeded ``numpy`` generator; the length
  is the clip's, floored to a multiple of 4, and the real segment is its first that many frames.
* **size**: by default as many instances as the pool covers once (``len(pool) // N``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from motionlab.data import Caption, MotionClip, MotionDataset, floor_to_unit
from motionlab.multimotion.stitch import concatenate_segments

MAX_ACTIONS = 32  # M2D2M's Table 4 goes up to N = 32
# The shortest action every compared method can take: SLERP and Handshake give 20 frames of each end of an inner action
# to a 40-frame transition (baselines.DEFAULT_TRANSITION) and need 4 frames left. HumanML3D-length clips start at 40.
MIN_ACTION_FRAMES = 44


@dataclass(frozen=True)
class PoolClip:
    clip: MotionClip
    family: str
    captions: tuple[Caption, ...]  # the captions that may be drawn


@dataclass(frozen=True)
class MultiActionInstance:
    """N actions to generate in a row, with the real clips they were drawn from."""

    clips: tuple[MotionClip, ...]
    captions: tuple[Caption, ...]
    families: tuple[str, ...]
    lengths: tuple[int, ...]  # frames, multiples of 4

    @property
    def texts(self) -> list[str]:
        return [c.text for c in self.captions]

    @property
    def real_segments(self) -> list[np.ndarray]:
        """The real clips cropped to the instance's lengths (raw features)."""
        return [c.features[:n] for c, n in zip(self.clips, self.lengths, strict=True)]

    def real_concat(self) -> tuple[np.ndarray, list[int]]:
        """The real clips played back to back ("ground truth (concat)"): features and boundaries."""
        return concatenate_segments(self.real_segments)


def _single_verb(caption: Caption) -> str | None:
    verbs = [tok.split("/")[0] for tok in caption.tokens if tok.endswith("/VERB")]
    return verbs[0] if len(verbs) == 1 else None


def single_action_pool(
    dataset: MotionDataset, split: str = "test", unit: int = 4, min_frames: int = MIN_ACTION_FRAMES
) -> list[PoolClip]:
    """Single-action clips of ``split`` of at least ``min_frames`` (after flooring to ``unit``), with their family
    (see the module docstring)."""
    meta_path = dataset.root / "meta.json"
    meta = json.loads(meta_path.read_text())["clips"] if meta_path.is_file() else None
    pool = []
    for clip in dataset.split(split):
        if floor_to_unit(clip.length, unit) < max(unit, min_frames):
            continue
        if meta is not None:
            info = meta.get(clip.name)
            if info is not None and info.get("single_action"):
                pool.append(PoolClip(clip, str(info["family"]), tuple(clip.captions)))
            continue
        tagged = [(c, _single_verb(c)) for c in clip.captions]
        tagged = [(c, v) for c, v in tagged if v is not None]
        if tagged:
            pool.append(PoolClip(clip, tagged[0][1], tuple(c for c, _ in tagged)))
    return pool


def build_multi_action_testset(
    dataset: MotionDataset | Sequence[PoolClip],
    n_actions: int = 4,
    *,
    seed: int = 0,
    n_instances: int | None = None,
    split: str = "test",
    distinct_families: bool = True,
    max_actions: int = MAX_ACTIONS,
    unit: int = 4,
) -> list[MultiActionInstance]:
    """Seeded instances of ``n_actions`` single-action captions (see the module docstring).

    ``dataset`` is a :class:`~motionlab.data.MotionDataset` (its ``split`` is pooled) or a ready pool.
    """
    if not isinstance(n_actions, int) or not 1 <= n_actions <= max_actions:
        raise ValueError(f"n_actions must be an int in [1, max_actions={max_actions}], got {n_actions!r}")
    pool = single_action_pool(dataset, split, unit) if isinstance(dataset, MotionDataset) else list(dataset)
    by_family: dict[str, list[PoolClip]] = {}
    for p in pool:
        by_family.setdefault(p.family, []).append(p)
    families = sorted(by_family)
    if distinct_families and n_actions > len(families):
        raise ValueError(
            f"n_actions={n_actions} distinct families requested but the pool has only "
            f"{len(families)}; pass distinct_families=False to allow repeats"
        )
    if not distinct_families and n_actions > len(pool):
        raise ValueError(f"n_actions={n_actions} exceeds the {len(pool)} single-action clips of the pool")
    n_instances = len(pool) // n_actions if n_instances is None else n_instances
    if not isinstance(n_instances, int) or n_instances < 1:
        raise ValueError(f"n_instances must be a positive int, got {n_instances!r} (pool of {len(pool)} clips)")
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n_instances):
        if distinct_families:
            picks = [by_family[families[i]] for i in rng.choice(len(families), n_actions, replace=False)]
            chosen = [group[int(rng.integers(len(group)))] for group in picks]
        else:
            chosen = [pool[i] for i in rng.choice(len(pool), n_actions, replace=False)]
        captions = tuple(p.captions[int(rng.integers(len(p.captions)))] for p in chosen)
        out.append(
            MultiActionInstance(
                clips=tuple(p.clip for p in chosen),
                captions=captions,
                families=tuple(p.family for p in chosen),
                lengths=tuple(floor_to_unit(p.clip.length, unit) for p in chosen),
            )
        )
    return out
