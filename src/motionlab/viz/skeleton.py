"""Stick figures: a static pose and a small animation that embeds in a book page.

Animations are rendered with matplotlib's ``to_jshtml``: every frame becomes a PNG inside the page, so they
play offline. Keep them small (a few dozen frames, small figures): the page carries every frame.
"""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation

from ..io.palette import CHAIN_COLORS
from ..representation import Skeleton, get_skeleton, skeleton_for_joint_count


def _as_motion(joints, skeleton) -> tuple[np.ndarray, Skeleton]:
    arr = np.asarray(joints.detach().cpu() if hasattr(joints, "detach") else joints, dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[-1] != 3:
        raise ValueError(f"joints must have shape (T, J, 3) or (J, 3), got {arr.shape}")
    sk = get_skeleton(skeleton) if skeleton is not None else skeleton_for_joint_count(arr.shape[1])
    if arr.shape[1] != sk.n_joints:
        raise ValueError(f"{sk.name} has {sk.n_joints} joints, got {arr.shape[1]}")
    if not np.isfinite(arr).all():
        raise ValueError("joints contain NaN or inf values")
    return arr * sk.meters_per_unit, sk


def _setup_axes(ax, motion: np.ndarray, radius: float | None = None):
    # Y is up in HumanML3D; matplotlib's 3D z is up, so plot (x, z, y).
    centre = motion[:, 0].mean(axis=0)
    r = radius or max(0.8, 0.5 * float(np.ptp(motion[..., [0, 2]], axis=(0, 1)).max()) + 0.4)
    ax.set_xlim(centre[0] - r, centre[0] + r)
    ax.set_ylim(centre[2] - r, centre[2] + r)
    ax.set_zlim(0, max(2.0, float(motion[..., 1].max()) + 0.1))
    ax.set_box_aspect((1, 1, max(2.0, float(motion[..., 1].max()) + 0.1) / (2 * r)))
    ax.view_init(elev=15, azim=-60)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_zticks([])
    ax.xaxis.pane.set_alpha(0.0)
    ax.yaxis.pane.set_alpha(0.0)
    ax.zaxis.pane.set_alpha(0.15)


def _draw_pose(ax, pose: np.ndarray, sk: Skeleton, lines=None):
    out = []
    for k, chain in enumerate(sk.chains):
        pts = pose[list(chain)]
        color = CHAIN_COLORS[k % len(CHAIN_COLORS)]
        if lines is None:
            (line,) = ax.plot(pts[:, 0], pts[:, 2], pts[:, 1], color=color, lw=2.0, marker="o", ms=2)
            out.append(line)
        else:
            lines[k].set_data_3d(pts[:, 0], pts[:, 2], pts[:, 1])
    return out or lines


def plot_pose(pose, skeleton: str | Skeleton | None = None, ax=None, title: str | None = None):
    """Draw one pose ``(J, 3)`` as a stick figure; returns the axes."""
    motion, sk = _as_motion(pose, skeleton)
    if ax is None:
        ax = plt.figure(figsize=(3, 3)).add_subplot(projection="3d")
    _setup_axes(ax, motion)
    _draw_pose(ax, motion[0], sk)
    if title:
        ax.set_title(title, fontsize=9)
    return ax


def animate_motions(
    motions: Sequence | np.ndarray,
    titles: Sequence[str] | None = None,
    skeleton: str | Skeleton | None = None,
    fps: float | None = None,
    max_frames: int = 60,
    size: float = 2.6,
    trail_joint: int | None = None,
) -> animation.FuncAnimation:
    """An animation of one or several motions ``(T, J, 3)`` side by side (same frame clock).

    Long clips are subsampled in time to at most ``max_frames`` frames (the playback speed stays real time).
    ``trail_joint`` draws the path of one joint (e.g. 20, the left wrist) up to the current frame. Show it in a
    notebook or book page with :func:`motionlab.book.embed_animation` (plays offline).
    """
    if isinstance(motions, np.ndarray) or hasattr(motions, "detach"):
        motions = [motions]
    prepared = [_as_motion(m, skeleton) for m in motions]
    if titles is not None and len(titles) != len(prepared):
        raise ValueError(f"got {len(titles)} titles for {len(prepared)} motions")
    n_frames = max(m.shape[0] for m, _ in prepared)
    stride = max(1, int(np.ceil(n_frames / max_frames)))
    frames = list(range(0, n_frames, stride))
    rate = fps or prepared[0][1].fps

    fig = plt.figure(figsize=(size * len(prepared), size))
    artists = []
    for i, (motion, sk) in enumerate(prepared):
        ax = fig.add_subplot(1, len(prepared), i + 1, projection="3d")
        _setup_axes(ax, motion)
        if titles is not None:
            ax.set_title(titles[i], fontsize=9)
        lines = _draw_pose(ax, motion[0], sk)
        trail = ax.plot([], [], [], color="#9467bd", lw=1)[0] if trail_joint is not None else None
        artists.append((motion, sk, lines, trail))
    fig.tight_layout()

    def update(frame):
        for motion, sk, lines, trail in artists:
            t = min(frame, len(motion) - 1)
            _draw_pose(None, motion[t], sk, lines)
            if trail is not None:
                path = motion[: t + 1, trail_joint]
                trail.set_data_3d(path[:, 0], path[:, 2], path[:, 1])
        return []

    anim = animation.FuncAnimation(fig, update, frames=frames, interval=1000.0 * stride / rate, blit=False)
    plt.close(fig)  # the animation owns the figure; avoid a duplicate still image in notebooks
    return anim
