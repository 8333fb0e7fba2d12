"""How close is the embedded data to real capture where sJPE looks: the jerk of the feet and wrists.

sJPE compares a decoder's jerk with the ground truth's frame by frame, so it is only as meaningful as the
ground truth's own fine motion: on data without it, any wiggle reads as "noise". These helpers put the
embedded clips beside real ones (HumanML3D joints, HumanML3D features, CMU BVH takes) on one yardstick,
the percentiles of the jerk magnitudes sJPE compares (:func:`~motionlab.metrics.sjpe_jerk_magnitudes`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from motionlab.metrics.sjpe import sjpe_jerk_magnitudes

PERCENTILES = (10, 50, 90)


def jerk_percentiles(clips: Sequence[np.ndarray], percentiles: Sequence[float] = PERCENTILES) -> dict[str, float]:
    """``{"p10": .., "p50": .., "p90": ..}`` of the sJPE joints' jerk magnitudes (m/s³) over ``(T, 22, 3)`` clips."""
    magnitudes = sjpe_jerk_magnitudes(clips).ravel()
    return {f"p{p:g}": float(np.percentile(magnitudes, p)) for p in percentiles}


def embedded_sample(n: int = 100, *, fine: bool = True, seed: int = 0, n_clips: int = 3000) -> list[np.ndarray]:
    """Joints ``(T, 22, 3)`` of ``n`` clips spread evenly over a dataset of ``n_clips`` (the same actions and
    parameters the dataset's clips get), through the features and back as the files on disk hold them.
    ``fine=False`` leaves out the fine structure."""
    from motionlab.representation import joints_to_features, recover_from_ric

    from .generator import generate_clip
    from .writer import _rng, plan_families

    if not 1 <= n <= n_clips:
        raise ValueError(f"n must be in [1, n_clips={n_clips}], got {n}")
    specs = plan_families(n_clips, seed)
    out = []
    for index in np.linspace(0, n_clips - 1, n).astype(int):
        clip = generate_clip(specs[index], _rng(seed, 1, int(index)), fine=fine)
        features = joints_to_features(clip.joints, "t2m", retarget_to_target=False)
        out.append(np.asarray(recover_from_ric(features, 22)))
    return out


def real_reference_clips(root: str | Path) -> dict[str, np.ndarray]:
    """Real joint clips ``(T, 22, 3)`` in metres at 20 fps from a folder laid out like ``../shared/data``.

    Reads what is there: ``humanml3d-sample/new_joints/*.npy``, ``momask-example/*.npy`` (263-d features,
    recovered to joints) and ``cmu-bvh/*.bvh`` (converted with the CMU mapping). Raises if none is found.
    """
    from motionlab.io.bvh_import import bvh_to_joints
    from motionlab.representation import recover_from_ric

    root = Path(root)
    clips: dict[str, np.ndarray] = {}
    for path in sorted((root / "humanml3d-sample" / "new_joints").glob("*.npy")):
        clips[f"HumanML3D {path.stem}"] = np.load(path).astype(np.float64)
    for path in sorted((root / "momask-example").glob("*.npy")):
        clips[f"HumanML3D {path.stem} (features)"] = np.asarray(recover_from_ric(np.load(path).astype(np.float64), 22))
    for path in sorted((root / "cmu-bvh").glob("*.bvh")):
        clips[f"CMU {path.stem}"] = bvh_to_joints(path)
    if not clips:
        raise FileNotFoundError(f"no real clips under {root} (expected humanml3d-sample/, momask-example/, cmu-bvh/)")
    return clips


__all__ = ["PERCENTILES", "embedded_sample", "jerk_percentiles", "real_reference_clips"]
