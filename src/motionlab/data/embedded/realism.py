"""How close is the embedded data to real capture, on the yardsticks the papers' metrics depend on.

* **Fine motion** (sJPE): sJPE compares a decoder's jerk with the ground truth's frame by frame, so it is only
  as meaningful as the ground truth's own fine motion: on data without it, any wiggle reads as "noise".
  :func:`jerk_percentiles` gives the percentiles of the jerk magnitudes sJPE compares
  (:func:`~motionlab.metrics.sjpe_jerk_magnitudes`).
* **Clip ends** (M2D2M's "ground truth (concat)" Jerk): real clips are cut out of longer takes, so they often
  begin and end while the body moves, and two of them played back to back jump. :func:`edge_speeds` measures
  how fast a clip moves at its ends against its middle, :func:`seam_pose_jump` how far the pose jumps where
  two clips meet.

Real clips (HumanML3D joints and features, CMU BVH takes) are read with :func:`real_reference_clips`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from motionlab.metrics.sjpe import sjpe_jerk_magnitudes
from motionlab.representation import feature_slices, recover_from_ric

from .body import FPS

PERCENTILES = (10, 50, 90)
EDGE_FRAMES = 5  # a speed is the distance covered in this many frames (0.25 s at 20 fps) over that time
# An end "moves" when its joints' mean speed reaches this (m/s). The CMU takes where they start or stop standing:
# 0.02-0.11; the embedded idle pose, with its wobble and sway: 0.04-0.11 (10th-90th percentile); windows cut at
# random places out of the real takes: median 0.5. A ratio to the clip's own median speed would not do: an arm
# action's median is hardly above its idle frames' speed.
MOVING_SPEED = 0.15


def jerk_percentiles(clips: Sequence[np.ndarray], percentiles: Sequence[float] = PERCENTILES) -> dict[str, float]:
    """``{"p10": .., "p50": .., "p90": ..}`` of the sJPE joints' jerk magnitudes (m/s³) over ``(T, 22, 3)`` clips."""
    magnitudes = sjpe_jerk_magnitudes(clips).ravel()
    return {f"p{p:g}": float(np.percentile(magnitudes, p)) for p in percentiles}


def embedded_sample(
    n: int = 100, *, fine: bool = True, cuts: bool = True, seed: int = 0, n_clips: int = 3000
) -> list[np.ndarray]:
    """Joints ``(T, 22, 3)`` of ``n`` clips spread evenly over a dataset of ``n_clips`` (the clips the dataset
    gets), through the features and back as the files on disk hold them. ``fine=False`` leaves out the fine
    structure, ``cuts=False`` the cuts (each clip shows its whole action, from rest to rest)."""
    from motionlab.representation import joints_to_features

    from .generator import generate_clip
    from .writer import _rng, plan_families

    if not 1 <= n <= n_clips:
        raise ValueError(f"n must be in [1, n_clips={n_clips}], got {n}")
    specs = plan_families(n_clips, seed)
    out = []
    for index in np.linspace(0, n_clips - 1, n).astype(int):
        clip = generate_clip(specs[index], _rng(seed, 1, int(index)), fine=fine, cuts=cuts)
        features = joints_to_features(clip.joints, "t2m", retarget_to_target=False)
        out.append(np.asarray(recover_from_ric(features, 22)))
    return out


def edge_speeds(features: np.ndarray) -> dict[str, float]:
    """How fast a clip moves at its ends and in its middle, from its HumanML3D features ``(T, 263)``.

    A speed here is the distance covered in :data:`EDGE_FRAMES` frames (a quarter of a second) divided by that
    time, in m/s: over so short a span it is the motion, while capture jitter and the embedded data's fine
    structure, which go back and forth from frame to frame, mostly cancel. Of the root (``root_*``) and
    averaged over the 22 joints (``joints_*``, world frame, so a walk's travel counts as well as a wave's arm):
    ``*_start`` over the first frames, ``*_end`` over the last, ``*_mid`` the median over the clip.
    ``moving_start`` and ``moving_end`` (1.0 or 0.0) say whether the joints' speed there reaches
    :data:`MOVING_SPEED`.
    """
    joints = np.asarray(recover_from_ric(np.asarray(features, np.float32), 22), np.float64)  # (T, 22, 3)
    if len(joints) < 2 * EDGE_FRAMES + 1:
        raise ValueError(f"a clip needs at least {2 * EDGE_FRAMES + 1} frames, got {len(joints)}")
    speed = np.linalg.norm(joints[EDGE_FRAMES:] - joints[:-EDGE_FRAMES], axis=-1) * FPS / EDGE_FRAMES  # (T-k, 22)
    out = {}
    for name, s in (("root", speed[:, 0]), ("joints", speed.mean(axis=1))):
        out |= {f"{name}_start": float(s[0]), f"{name}_end": float(s[-1]), f"{name}_mid": float(np.median(s))}
    for end in ("start", "end"):
        out[f"moving_{end}"] = float(out[f"joints_{end}"] >= MOVING_SPEED)
    return out


def seam_pose_jump(before: np.ndarray, after: np.ndarray) -> float:
    """Mean distance (m) over the joints between the last pose of ``before`` and the first of ``after``
    (HumanML3D features ``(T, 263)``), in the body's own frame: the jump a concatenation of the two makes.

    The poses are the features' root-relative joint positions (``ric``), which face +z in every frame, so
    where the clips stand and which way they face does not count, only the posture (and the root height)."""
    ric = feature_slices()["ric"]
    a, b = np.asarray(before)[-1, ric].reshape(-1, 3), np.asarray(after)[0, ric].reshape(-1, 3)
    return float(np.linalg.norm(b - a, axis=-1).mean())


def real_reference_clips(root: str | Path) -> dict[str, np.ndarray]:
    """Real joint clips ``(T, 22, 3)`` in metres at 20 fps from a folder laid out like ``../shared/data``.

    Reads what is there: ``humanml3d-sample/new_joints/*.npy``, ``momask-example/*.npy`` (263-d features,
    recovered to joints) and ``cmu-bvh/*.bvh`` (converted with the CMU mapping). Raises if none is found.
    """
    from motionlab.io.bvh_import import bvh_to_joints

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


__all__ = [
    "EDGE_FRAMES",
    "MOVING_SPEED",
    "PERCENTILES",
    "edge_speeds",
    "embedded_sample",
    "jerk_percentiles",
    "real_reference_clips",
    "seam_pose_jump",
]
