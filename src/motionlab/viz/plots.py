"""Static plots: joint trajectories and their jerk, and the layout of the feature vector."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np

from ..metrics.jerk import finite_difference_jerk
from ..representation import Skeleton, feature_slices, get_skeleton

GROUP_COLORS = {
    "root_rot_vel": "#8c564b",
    "root_lin_vel": "#e377c2",
    "root_height": "#7f7f7f",
    "ric": "#1f77b4",
    "rot": "#2ca02c",
    "local_vel": "#ff7f0e",
    "foot_contact": "#d62728",
}


def plot_feature_layout(skeleton: str | Skeleton = "t2m", ax=None):
    """A horizontal bar showing where each feature group lives in the vector."""
    sk = get_skeleton(skeleton)
    if ax is None:
        _, ax = plt.subplots(figsize=(8, 1.4))
    for name, sl in feature_slices(sk).items():
        ax.barh(0, sl.stop - sl.start, left=sl.start, color=GROUP_COLORS[name], edgecolor="white")
        label = f"{name}\n{sl.start}:{sl.stop}"
        ax.text(
            (sl.start + sl.stop) / 2,
            0,
            label if sl.stop - sl.start > 12 else "",
            ha="center",
            va="center",
            fontsize=7,
            color="white",
        )
    small = [n for n, sl in feature_slices(sk).items() if sl.stop - sl.start <= 12]
    ax.legend(
        handles=[plt.Rectangle((0, 0), 1, 1, color=GROUP_COLORS[n]) for n in small],
        labels=small,
        fontsize=7,
        ncol=len(small),
        loc="upper center",
        bbox_to_anchor=(0.5, -0.7),
        frameon=False,
    )
    ax.set_xlim(0, sk.feature_dim)
    ax.set_yticks([])
    ax.set_xlabel(f"feature index ({sk.name}: {sk.feature_dim} dims)")
    return ax


def plot_trajectories(
    motions: Mapping[str, np.ndarray],
    joint: int,
    skeleton: str | Skeleton = "t2m",
    axis: int = 1,
    fps: float | None = None,
    axes=None,
):
    """Position of one joint along one axis (top) and its jerk magnitude (bottom) for several motions.

    ``motions`` maps a label (e.g. "ground truth", "VQ decoder", "DisCoRD") to joints ``(T, J, 3)``; this is
    the kind of figure DisCoRD uses to show frame-wise noise and under-reconstruction.
    """
    sk = get_skeleton(skeleton)
    if not motions:
        raise ValueError("motions is empty")
    if not 0 <= joint < sk.n_joints:
        raise ValueError(f"joint must be in [0, {sk.n_joints}), got {joint}")
    if axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0 (x), 1 (y) or 2 (z), got {axis}")
    rate = fps or sk.fps
    if axes is None:
        _, axes = plt.subplots(2, 1, figsize=(7, 4), sharex=True)
    for label, joints in motions.items():
        joints = np.asarray(joints, dtype=np.float64) * sk.meters_per_unit
        t = np.arange(len(joints)) / rate
        axes[0].plot(t, joints[:, joint, axis], label=label, lw=1.3)
        jerk = np.linalg.norm(finite_difference_jerk(joints[:, joint], rate, axis=0), axis=-1)  # (T-3,)
        axes[1].plot(t[3:], jerk, label=label, lw=1.0)
    axes[0].set_ylabel(f"{'xyz'[axis]} (m)")
    axes[1].set_ylabel("jerk (m/s³)")
    axes[1].set_xlabel("time (s)")
    axes[0].set_title(f"{sk.joint_names[joint]}", fontsize=10)
    axes[0].legend(fontsize=8)
    return axes
