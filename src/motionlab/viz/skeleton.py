"""Stick figures: a static pose and a small animation that embeds in a book page.

Animations are rendered with matplotlib's ``to_jshtml``: every frame becomes a PNG inside the page, so they
play offline. Keep them short (a few dozen frames): the page carries every frame, at the figure's dpi. Each motion
gets a panel at least :data:`MIN_PANEL_PX` pixels tall; panels wrap into rows so that the player stays within
:data:`PAGE_WIDTH` inches (the book's column), and long titles wrap over lines instead of being cut.
"""

from __future__ import annotations

import math
import numbers
import textwrap
from collections.abc import Sequence

import matplotlib as mpl
import matplotlib.pyplot as plt
import numpy as np
from matplotlib import animation

from ..io.html import SEGMENT_COLORS, check_segments
from ..io.palette import CHAIN_COLORS
from ..representation import Skeleton, get_skeleton, skeleton_for_joint_count

MIN_PANEL_PX = 300  # the default height of one motion's panel, in pixels at the figure's dpi
PAGE_WIDTH = 7.4  # inches: the book's column at its dpi; wider figures are shrunk on the page
PANEL_ASPECT = 1.0  # width / height of a motion's panel (matplotlib draws a 3-D scene in a square)
PANEL_ZOOM = 1.4  # the 3-D box fills the panel (matplotlib leaves a wide margin around it at zoom 1)
LINE_INCHES = 0.17  # one line of 9-point text, with its leading


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


def _setup_axes(ax, motion: np.ndarray, radius: float | None = None, zoom: float = 1.0, min_radius: float = 0.8):
    # Y is up in HumanML3D; matplotlib's 3D z is up, so plot (x, z, y).
    centre = motion[:, 0].mean(axis=0)
    r = radius or max(min_radius, 0.5 * float(np.ptp(motion[..., [0, 2]], axis=(0, 1)).max()) + 0.4)
    ax.set_xlim(centre[0] - r, centre[0] + r)
    ax.set_ylim(centre[2] - r, centre[2] + r)
    ax.set_zlim(0, max(2.0, float(motion[..., 1].max()) + 0.1))
    ax.set_box_aspect((1, 1, max(2.0, float(motion[..., 1].max()) + 0.1) / (2 * r)), zoom=zoom)
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


def wrap_title(title: str, width_inches: float, fontsize: float = 9) -> str:
    """``title`` broken over lines that fit ``width_inches`` at ``fontsize`` points (never cut)."""
    if not isinstance(title, str):
        raise ValueError(f"titles must be str, got {type(title).__name__}")
    chars = max(8, int(width_inches * 72 / (0.55 * fontsize)))  # 0.55 em: a wide average glyph
    return textwrap.fill(title, chars, break_long_words=True) if title else ""


def segment_at(segments: Sequence[tuple[int, str]], frame: int) -> int:
    """Index of the segment that plays at ``frame`` (segments as returned by :func:`~motionlab.io.html.check_segments`,
    the rule the standalone HTML player shares)."""
    return max(i for i, (start, _) in enumerate(segments) if start <= frame)


def panel_grid(n: int, height: float, width: float = PAGE_WIDTH) -> tuple[int, int, float]:
    """Rows, columns and panel width (inches) for ``n`` panels ``height`` inches tall within ``width`` inches:
    as many per row as fit at :data:`PANEL_ASPECT`, rows filled evenly (4 panels: 2 × 2, not 3 + 1)."""
    panel_w = min(PANEL_ASPECT * height, width)
    fit = max(1, int(width / panel_w + 1e-9))
    rows = math.ceil(n / fit)
    return rows, math.ceil(n / rows), panel_w


def _draw_timeline(ax, starts: list[int], n_frames: int, rate: float):
    """The segments as numbered spans along the clip's seconds, each boundary a dark line; returns the cursor."""
    ends = [*starts[1:], n_frames]
    for k, (a, b) in enumerate(zip(starts, ends)):
        ax.axvspan(a / rate, b / rate, color=SEGMENT_COLORS[k % len(SEGMENT_COLORS)], lw=0)
        ax.text((a + b) / 2 / rate, 0.5, str(k + 1), ha="center", va="center", fontsize=8)
        if k:
            ax.axvline(a / rate, color="#333333", lw=1.2, gid="boundary")
    ax.set_xlim(0, n_frames / rate)
    ax.set_ylim(0, 1)
    ax.set_yticks([])
    ax.grid(False)
    ax.tick_params(axis="x", labelsize=7, length=2, pad=1)
    ax.set_xticks([a / rate for a in starts[1:]], [f"{a / rate:.1f} s" for a in starts[1:]])
    for spine in ax.spines.values():
        spine.set_visible(False)
    return ax.axvline(0.0, color="#d55e00", lw=2, gid="cursor")


def animate_motions(
    motions: Sequence | np.ndarray,
    titles: Sequence[str] | None = None,
    skeleton: str | Skeleton | None = None,
    fps: float | None = None,
    max_frames: int = 60,
    size: float | None = None,
    trail_joint: int | None = None,
    segments: Sequence[tuple[int, str]] | None = None,
    width: float = PAGE_WIDTH,
) -> animation.FuncAnimation:
    """An animation of one or several motions ``(T, J, 3)`` on the same frame clock.

    Each motion gets a panel ``size`` inches tall (default: :data:`MIN_PANEL_PX` pixels at the figure's dpi); the
    panels wrap into rows so that the figure is at most ``width`` inches wide. Titles wrap over lines. Long clips
    are subsampled in time to at most ``max_frames`` frames (the playback speed stays real time). ``trail_joint``
    draws the path of one joint (e.g. 20, the left wrist) up to the current frame.

    ``segments=[(start_frame, label), ...]`` (frames of the motions, the first at 0) names what plays when, e.g. the
    actions of a multi-action motion: the label of the current segment is shown above the panels, updated every
    frame, and a timeline under them marks each boundary and where the player is. Show the animation in a notebook
    or book page with :func:`motionlab.book.embed_animation` (plays offline).
    """
    if isinstance(motions, np.ndarray) or hasattr(motions, "detach"):
        motions = [motions]
    prepared = [_as_motion(m, skeleton) for m in motions]
    if not prepared:
        raise ValueError("motions must hold at least one motion")
    if titles is not None and len(titles) != len(prepared):
        raise ValueError(f"got {len(titles)} titles for {len(prepared)} motions")
    dpi = float(mpl.rcParams["figure.dpi"])
    inches = (1.0 if size is None else size, width)
    if not all(isinstance(v, numbers.Real) and not isinstance(v, bool) and v > 0 for v in inches):
        raise ValueError(f"size and width must be positive inches, got size={size!r}, width={width!r}")
    height = MIN_PANEL_PX / dpi if size is None else float(size)
    n_frames = max(m.shape[0] for m, _ in prepared)
    segments = None if segments is None else check_segments(segments, n_frames)
    stride = max(1, int(np.ceil(n_frames / max_frames)))
    frames = list(range(0, n_frames, stride))
    rate = fps or prepared[0][1].fps

    rows, cols, panel_w = panel_grid(len(prepared), height, width)
    fig_w = cols * panel_w
    wrapped = [wrap_title(t, panel_w) for t in titles] if titles is not None else [""] * len(prepared)
    title_lines = [
        max((w.count("\n") + 1 if w else 0) for w in wrapped[r * cols : (r + 1) * cols]) for r in range(rows)
    ]
    label_lines = 0
    if segments is not None:
        label_lines = max(
            wrap_title(f"{len(segments)}/{len(segments)}: {t}", fig_w).count("\n") + 1 for _, t in segments
        )
    top = label_lines * LINE_INCHES + (0.08 if segments else 0.0)
    bottom = 0.42 if segments else 0.0
    row_h = [height + n * LINE_INCHES for n in title_lines]
    fig_h = top + sum(row_h) + bottom
    fig = plt.figure(figsize=(fig_w, fig_h))

    artists = []
    for i, (motion, sk) in enumerate(prepared):
        r, c = divmod(i, cols)
        y_row = fig_h - top - sum(row_h[: r + 1])
        n_in_row = min(cols, len(prepared) - r * cols)
        x0 = (fig_w - n_in_row * panel_w) / 2 + c * panel_w  # a short last row is centred
        ax = fig.add_axes([x0 / fig_w, y_row / fig_h, panel_w / fig_w, height / fig_h], projection="3d")
        _setup_axes(ax, motion, zoom=PANEL_ZOOM, min_radius=0.6)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # the box's edges would reach into the next panel
            axis.line.set_visible(False)
        ax.zaxis.pane.set_clip_path(ax.patch)  # the floor stays inside its panel
        ax.zaxis.pane.set_alpha(0.3)
        if wrapped[i]:
            at = ((x0 + panel_w / 2) / fig_w, (y_row + row_h[r] - 0.03) / fig_h)
            fig.text(*at, wrapped[i], ha="center", va="top", fontsize=9)
        lines = _draw_pose(ax, motion[0], sk)
        trail = ax.plot([], [], [], color="#9467bd", lw=1)[0] if trail_joint is not None else None
        artists.append((motion, sk, lines, trail))

    label = cursor = None
    if segments is not None:
        label = fig.text(0.5, 1 - 0.04 / fig_h, "", ha="center", va="top", fontsize=9, weight="bold", gid="segment")
        timeline = fig.add_axes([0.04, 0.17 / fig_h, 0.92, 0.2 / fig_h], gid="timeline")
        cursor = _draw_timeline(timeline, [s for s, _ in segments], n_frames, rate)

    def update(frame):
        for motion, sk, lines, trail in artists:
            t = min(frame, len(motion) - 1)
            _draw_pose(None, motion[t], sk, lines)
            if trail is not None:
                path = motion[: t + 1, trail_joint]
                trail.set_data_3d(path[:, 0], path[:, 2], path[:, 1])
        if segments is not None:
            k = segment_at(segments, frame)
            label.set_text(wrap_title(f"{k + 1}/{len(segments)}: {segments[k][1]}", fig_w))
            cursor.set_xdata([frame / rate, frame / rate])
        return []

    update(0)
    anim = animation.FuncAnimation(fig, update, frames=frames, interval=1000.0 * stride / rate, blit=False)
    plt.close(fig)  # the animation owns the figure; avoid a duplicate still image in notebooks
    return anim
