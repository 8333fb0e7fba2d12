"""Static plots: joint trajectories and their jerk, the layout of the feature vector, training curves, 2-D codebooks
and point clouds; and a widget to explore trajectories."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

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
    # beside the panel, never over the data (a joint's curves fill the panel's width)
    axes[0].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return axes


def panel_axes(n: int, axes=None, *, figsize: tuple[float, float], what: str = "panels", **subplots) -> np.ndarray:
    """``n`` axes in a row, flat: the caller's ``axes`` (checked to be ``n``), or a new figure's (``subplots`` go to
    ``plt.subplots``, e.g. ``sharey=True``)."""
    if axes is None:
        _, axes = plt.subplots(1, n, figsize=figsize, squeeze=False, **subplots)
    axes = np.atleast_1d(axes).ravel()
    if len(axes) != n:
        raise ValueError(f"{n} {what} need as many axes, got {len(axes)}")
    return axes


def plot_history(
    histories: Mapping[str, Sequence[Mapping[str, float]]],
    keys: Mapping[str, str] | Sequence[str],
    *,
    log: Sequence[str] = (),
    xlabel: str = "step",
    axes=None,
    figsize: tuple[float, float] = (7.4, 2.4),
):
    """Training curves: one panel per logged quantity, one line per run.

    ``histories`` maps a run's label to its logged rows (what :meth:`motionlab.train.Trainer.fit` returns: dicts with
    ``"step"`` and the quantities); ``keys`` names the quantities to draw, or maps each to its y label. Rows that lack
    a quantity (e.g. the validation rows of a training log) are skipped. Quantities in ``log`` get a log scale.
    Returns the axes, one per key.
    """
    labels = dict(keys) if isinstance(keys, Mapping) else {k: k for k in keys}
    if not histories or not labels:
        raise ValueError("need at least one history and one key")
    axes = panel_axes(len(labels), axes, figsize=figsize, what="keys")
    for ax, (key, ylabel) in zip(axes, labels.items()):
        drawn = 0
        for name, history in histories.items():
            rows = [row for row in history if key in row]
            if rows:
                ax.plot([row["step"] for row in rows], [row[key] for row in rows], label=name)
                drawn += 1
        if not drawn:
            raise ValueError(f"no history logged {key!r}")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        if key in log:
            ax.set_yscale("log")
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)  # beside, off the data
    return axes


def plot_codebook_snapshots(
    trace,
    data_at: Callable[[int], np.ndarray],
    axes=None,
    label: str = "",
    show_at: Sequence[int] = (10, 40, 100, 400),
    lim: float = 1.4,
):
    """A 2-D codebook at a few steps of its training (the saved steps nearest above ``show_at``): the data of that
    step in grey (``data_at(step) -> (N, 2)``), the codes in red. ``trace`` is a
    :class:`~motionlab.tokenizers.analysis.CodebookTrace` (``steps``, ``codebooks``). Returns the axes."""
    steps, codebooks = np.asarray(trace.steps), np.asarray(trace.codebooks)
    if codebooks.ndim != 3 or codebooks.shape[-1] != 2:
        raise ValueError(f"the trace must hold 2-D codebooks (S, K, 2), got {codebooks.shape}")
    if axes is None:
        _, axes = plt.subplots(1, len(show_at), figsize=(7.4, 2))
    axes = np.atleast_1d(axes).ravel()
    for ax, step in zip(axes, show_at, strict=True):
        i = min(int(np.searchsorted(steps, step)), len(steps) - 1)
        data = np.asarray(data_at(int(steps[i])))
        ax.scatter(*data.T, s=2, c="#bbbbbb")
        ax.scatter(*codebooks[i].T, s=14, c="#d62728")
        ax.set_title(f"{label}, step {steps[i]}" if label else f"step {steps[i]}", fontsize=8)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    return axes


def plot_clouds(
    clouds: Mapping[str, np.ndarray | None],
    axes=None,
    *,
    background: np.ndarray | None = None,
    colors: np.ndarray | None = None,
    point_size: float = 1.5,
    alpha: float = 0.5,
    lim: float = 3.2,
    fontsize: float = 8,
):
    """2-D point clouds ``(N, 2)``, one panel each (titled by its key), on equal square axes ``[-lim, lim]²``.

    ``background`` (e.g. a sample of the true distribution) is drawn in light grey under every cloud; ``colors``
    (``(N,)`` class ids, at most 10) colour the points; a cloud of ``None`` marks a panel "not possible".
    Returns the axes, in the order of ``clouds``.
    """
    if not clouds:
        raise ValueError("clouds is empty")
    axes = panel_axes(len(clouds), axes, figsize=(7.4, 2), what="clouds", sharex=True, sharey=True)
    for ax, (title, points) in zip(axes, clouds.items()):
        if background is not None:
            ax.scatter(*np.asarray(background)[:, :2].T, s=1, color="#ccc")
        if points is None:
            ax.text(0, 0, "not possible", ha="center", va="center", fontsize=fontsize)
        else:
            xy = np.asarray(points)
            if xy.ndim != 2 or xy.shape[1] != 2:
                raise ValueError(f"cloud {title!r} must have shape (N, 2), got {xy.shape}")
            style = {"c": colors, "cmap": "tab10", "vmin": 0, "vmax": 9} if colors is not None else {"color": "#1f77b4"}
            ax.scatter(xy[:, 0], xy[:, 1], s=point_size, alpha=alpha, **style)
        ax.set_title(title, fontsize=fontsize)
        ax.set_aspect("equal")
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
    return axes


def trajectory_explorer(
    motions_of: Callable[[int], Mapping[str, np.ndarray]],
    choices: Sequence[str],
    joint: int,
    skeleton: str | Skeleton = "t2m",
    axis: int = 1,
    figsize: tuple[float, float] = (7.4, 3.0),
) -> None:
    """A widget over :func:`plot_trajectories`: pick a clip (``choices[i]`` names clip ``i``), a joint and an axis;
    ``motions_of(i)`` gives that clip's motions (label -> joints ``(T, J, 3)``). ``joint`` and ``axis`` are the
    defaults shown. Displays the widget (and the figure of the default choice) in the running notebook."""
    import ipywidgets as widgets

    sk = get_skeleton(skeleton)
    if not choices:
        raise ValueError("choices is empty")
    if not 0 <= joint < sk.n_joints or axis not in (0, 1, 2):
        raise ValueError(f"need joint in [0, {sk.n_joints}) and axis in (0, 1, 2), got {joint} and {axis}")

    def show(clip: int, joint: int, axis: int) -> None:
        _, axes = plt.subplots(2, 1, figsize=figsize, sharex=True)
        plot_trajectories(motions_of(clip), joint, sk, axis=axis, axes=axes)
        plt.show()

    widgets.interact(
        show,
        clip=widgets.Dropdown(options=[(name, i) for i, name in enumerate(choices)], value=0, description="clip"),
        joint=widgets.Dropdown(
            options=[(n, j) for j, n in enumerate(sk.joint_names)], value=joint, description="joint"
        ),
        axis=widgets.ToggleButtons(options=[("x", 0), ("y (up)", 1), ("z", 2)], value=axis, description="axis"),
    )
