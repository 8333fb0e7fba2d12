"""Two-Phase Sampling (chapter 09): N action texts, ONE joint token sequence denoised from t = T_d down to T_s + 1,
split at the action boundaries, N sequences denoised on their own from T_s down to 1, then decoded and joined.

The numbers drawn come from the library: tokens per action and the boundary frames from
:class:`~motionlab.multimotion.SegmentLayout`, the steps of each phase from :func:`~motionlab.multimotion.phase_grid`
(the grid the sampler runs) and the share of tokens that already hold a code when the joint phase hands over from the
mask-and-replace schedule, 1 − γ̄_{T_s} / γ̄_{T_d} (the mask is absorbing and sampling starts from all masks).
:func:`mark_segments` marks the same boundaries and texts on the chapter's plots over time.
"""

from __future__ import annotations

import numbers
import textwrap
from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from motionlab.diffusion.schedule import Schedule, get_schedule
from motionlab.multimotion.tps import SegmentLayout, phase_grid

from ._draw import PALETTE, Canvas

WIDTH_IN = 7.4  # the page's column: wider figures are shrunk
MAX_ACTIONS_DRAWN = 6  # more columns than this leave no room for the texts
_W = 14.8  # canvas units (0.5 inch each); the height follows the texts
_LINE = 0.245  # one line of 7-point text, in canvas units
_X0, _X1 = 2.3, 14.7  # the token columns; the step axis sits left of them
_GAP = 0.18  # between two actions' columns after the split


def decided_share(schedule: Schedule, T_s: int) -> float:
    """Expected share of the positions that hold a code when the joint phase ends: 1 − γ̄_{T_s} / γ̄_T."""
    return 1.0 - float(schedule.gamma_bar[T_s] / schedule.gamma_bar[schedule.T])


def phase_steps(T: int, T_s: int, num_steps: int | None = None) -> tuple[int, int]:
    """Reverse jumps (network calls without guidance) of the joint and the independent phase on the sampler's grid."""
    grid = phase_grid(T, T_s, num_steps)
    joint = sum(1 for t in grid[:-1] if t > T_s)
    return joint, len(grid) - 1 - joint


def _steps(n: int) -> str:
    return f"{n} step" if n == 1 else f"{n} steps"


def _columns(tokens: Sequence[int]) -> list[tuple[float, float]]:
    """(x, width) of each action's column: proportional to its tokens, but at least 70 % of an equal share."""
    n, span = len(tokens), _X1 - _X0
    share = np.maximum(np.asarray(tokens, float) / sum(tokens), 0.7 / n)
    widths = share / share.sum() * span
    starts = _X0 + np.concatenate([[0.0], np.cumsum(widths)[:-1]])
    return list(zip(starts.tolist(), widths.tolist(), strict=True))


def _tokens_row(canvas: Canvas, x: float, w: float, y: float, n: int, decided: np.ndarray, h: float = 0.38) -> None:
    """``n`` token cells across ``[x, x + w]``: a code where ``decided`` is True, [MASK] elsewhere."""
    cell = w / n
    for i in range(n):
        kind = "token" if decided[i] else "noise"
        canvas.ax.add_patch(Rectangle((x + i * cell, y), cell, h, facecolor=PALETTE[kind], linewidth=0))
    canvas.ax.add_patch(Rectangle((x, y), w, h, facecolor="none", edgecolor=PALETTE["edge"], linewidth=0.8))


def two_phase(
    texts: Sequence[str],
    frames: Sequence[int],
    T: int = 100,
    T_s: int = 90,
    *,
    num_steps: int | None = None,
    schedule: Schedule | None = None,
    seed: int = 0,
) -> Figure:
    """Algorithm 1 for one instance: ``texts`` (one per action) of ``frames`` frames each (multiples of 4).

    Top to bottom: the texts; z_T, one all-[MASK] sequence of all the actions' tokens; the joint phase t = T … T_s+1;
    z_{T_s}, where the expected share of codes (:func:`decided_share` of ``schedule``, default the book's schedule with
    ``T`` steps) is drawn at positions picked with ``seed``; the split at the boundaries; the independent phase
    t = T_s … 1, one row per action with its own text; z_0 of each action; the decoded, joined motion with its
    boundary frames. The step axis on the left marks T, T_s and 0; the steps of each phase are counted on the
    sampler's grid (``num_steps`` as in :func:`~motionlab.multimotion.two_phase_sample`).
    """
    if isinstance(texts, str) or not isinstance(texts, Sequence) or not all(isinstance(t, str) for t in texts):
        raise ValueError(f"texts must be a list of str, one per action, got {texts!r}")
    if not 1 <= len(texts) <= MAX_ACTIONS_DRAWN:
        raise ValueError(f"the diagram draws 1 to {MAX_ACTIONS_DRAWN} actions, got {len(texts)}")
    if isinstance(frames, str) or not isinstance(frames, Sequence) or len(frames) != len(texts):
        raise ValueError(f"frames must hold one length per text ({len(texts)}), got {frames!r}")
    if not isinstance(T, numbers.Integral) or isinstance(T, bool) or T < 1:
        raise ValueError(f"T must be a positive int, got {T!r}")
    layout = SegmentLayout.from_frames(list(frames))  # checks the lengths: positive multiples of 4
    joint_steps, independent_steps = phase_steps(T, T_s, num_steps)  # checks T_s in [0, T]
    schedule = get_schedule(T=T) if schedule is None else schedule
    if not isinstance(schedule, Schedule) or schedule.T != T:
        raise ValueError(f"schedule must be a motionlab.diffusion.Schedule with T = {T} steps, got {schedule!r}")

    tokens = list(layout.tokens[0])
    total, n = sum(tokens), len(tokens)
    share = decided_share(schedule, T_s)
    rng = np.random.default_rng(seed)
    at_ts = rng.random(total) < share  # which positions hold a code at T_s: drawn at the expected rate
    cols = _columns(tokens)
    fs = 7.5
    # the texts, one column per action, wrapped (never cut) to their column; the box grows with the longest
    chars = [max(10, int(w * WIDTH_IN / _W * 72 / (0.6 * (fs - 0.5))) - 1) for _, w in cols]
    labels = [
        textwrap.fill(f"$y^{{{i + 1}}}$: {layout.frames(0)[i]} frames, {tokens[i]} tokens", c)
        + "\n"
        + textwrap.fill(f"“{text}”", c)
        for i, (text, c) in enumerate(zip(texts, chars, strict=True))
    ]
    h_text = max(label.count("\n") + 1 for label in labels) * _LINE + 0.3
    y_text = 7.95
    canvas = Canvas(_W, y_text + h_text + 0.1, inches_per_unit=WIDTH_IN / _W)
    for (x, w), label in zip(cols, labels, strict=True):
        canvas.box(x + 0.05, y_text, w - 0.1, h_text, label, "condition", fontsize=fs - 0.5)

    # z_T and the joint phase on ONE sequence
    y_zT, y_joint, y_zTs = 7.35, 6.0, 5.2
    _tokens_row(canvas, _X0, _X1 - _X0, y_zT, total, np.zeros(total, bool))
    canvas.text(_X0 + 0.1, y_zT + 0.19, f"$z_{{T_d}}$: one sequence of {total} [MASK] tokens", fontsize=fs, ha="left")
    joint = canvas.box(
        _X0,
        y_joint,
        _X1 - _X0,
        0.95,
        (
            f"joint phase, t = {T} … {T_s + 1} ({_steps(joint_steps)}): one sequence; every token attends to all "
            f"{total},\nand cross-attends to its own action's text"
            if joint_steps
            else "no joint phase ($T_s = T_d$): the sequence is split before the first step"
        ),
        "network",
        fontsize=fs,
    )
    canvas.arrow((_X0 + 0.6, y_zT), (_X0 + 0.6, joint.y + joint.h))
    canvas.arrow((_X0 + 0.6, y_joint), (_X0 + 0.6, y_zTs + 0.38))
    _tokens_row(canvas, _X0, _X1 - _X0, y_zTs, total, at_ts)
    canvas.text(
        _X1 - 0.1,
        y_zTs + 0.19,
        f"$z_{{T_s}}$: about {100 * share:.0f} % hold a code",
        fontsize=fs,
        ha="right",
        bbox=dict(boxstyle="round,pad=0.15", facecolor="white", edgecolor="none", alpha=0.85),
    )

    # the split, then each action on its own
    y_split, y_zi, y_ind, y_z0 = 4.75, 3.95, 2.6, 1.75
    offset = 0
    for i, ((x, w), n_i) in enumerate(zip(cols, tokens, strict=True)):
        xi, wi = x + _GAP / 2, w - _GAP
        canvas.arrow((x + w / 2, y_zTs), (xi + wi / 2, y_zi + 0.38))
        _tokens_row(canvas, xi, wi, y_zi, n_i, at_ts[offset : offset + n_i])
        alone = f"t = {T_s} … 1\n({_steps(independent_steps)})" if independent_steps else "no step\n($T_s = 0$)"
        box = canvas.box(xi, y_ind, wi, 0.95, f"{alone}\ntext $y^{{{i + 1}}}$ only", "network", fontsize=fs - 0.5)
        canvas.arrow((xi + wi / 2, y_zi), box.side("top"))
        canvas.arrow(box.side("bottom"), (xi + wi / 2, y_z0 + 0.38))
        _tokens_row(canvas, xi, wi, y_z0, n_i, np.ones(n_i, bool))
        canvas.text(xi + wi / 2, y_z0 + 0.19, f"$z_0^{{{i + 1}}}$", fontsize=fs)
        offset += n_i

    # decoded and joined
    y_out = 0.15
    bounds = layout.boundaries(0)
    where = ", ".join(str(b) for b in bounds) if bounds else "none (one action)"
    out = canvas.box(
        _X0,
        y_out,
        _X1 - _X0,
        0.95,
        f"concatenate $z_0^1 … z_0^{{{n}}}$, decode: one motion of {sum(layout.frames(0))} frames\n"
        f"boundaries at frames {where}",
        "data",
        fontsize=fs,
    )
    for x, w in cols:
        canvas.arrow((x + w / 2, y_z0), (x + w / 2, out.y + out.h))

    # the step axis: T at z_T, T_s at the split, 0 at z_0
    ax_x = 1.05
    marks = [(y_zT + 0.19, f"$t = T_d = {T}$"), (y_split, f"$T_s = {T_s}$:\nsplit"), (y_z0 + 0.19, "$t = 0$")]
    canvas.ax.plot([ax_x, ax_x], [y_z0 + 0.19, y_zT + 0.19], color=PALETTE["edge"], lw=1.0)
    for (y, text), color in zip(marks, (PALETTE["edge"], PALETTE["accent"], PALETTE["edge"]), strict=True):
        canvas.ax.plot([ax_x - 0.12, ax_x + 0.12], [y, y], color=color, lw=2.0 if color != PALETTE["edge"] else 1.0)
        canvas.text(ax_x - 0.2, y, text, fontsize=fs, ha="right", color=color)
    canvas.ax.plot([ax_x + 0.12, _X1], [y_split, y_split], color=PALETTE["accent"], lw=1.0, ls="--", zorder=0)
    canvas.text(ax_x + 0.25, (y_zT + y_split) / 2, "joint", fontsize=fs, ha="left", rotation=90)
    canvas.text(ax_x + 0.25, (y_split + y_z0) / 2, "independent", fontsize=fs, ha="left", rotation=90)
    for k, (kind, name) in enumerate((("token", "a code"), ("noise", "[MASK]"))):  # the cells' key
        canvas.strip(0.2, 0.75 - 0.5 * k, [""], cell=0.3, kinds=kind)
        canvas.text(0.6, 0.9 - 0.5 * k, name, fontsize=fs, ha="left")
    return canvas.finish()


def mark_segments(axes, boundaries: Sequence[int], texts: Sequence[str], fps: float, *, fontsize: float = 7) -> None:
    """Mark the actions on plots over time in seconds (call after plotting): a dashed line at each boundary on every
    axes of ``axes``, and each action's text over its segment above the first axes, wrapped to the segment's width
    (never cut). ``boundaries`` are frames, the first frame of every action but the first."""
    axes = list(np.atleast_1d(axes))
    if not axes:
        raise ValueError("axes must hold at least one matplotlib axes")
    if isinstance(texts, str) or len(texts) != len(boundaries) + 1:
        raise ValueError(f"need one text per action: {len(boundaries) + 1} for {len(boundaries)} boundaries")
    bounds = [int(b) for b in boundaries]
    if any(b <= 0 for b in bounds) or any(b <= a for a, b in zip(bounds, bounds[1:])):
        raise ValueError(f"boundaries must be positive and increasing frames, got {list(boundaries)}")
    if not (isinstance(fps, numbers.Real) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps!r}")
    for ax in axes:
        for b in bounds:
            ax.axvline(b / fps, color=PALETTE["edge"], ls="--", lw=0.9, gid="boundary")
    top = axes[0]
    lo, hi = top.get_xlim()
    fig_w = top.figure.get_size_inches()[0] * top.get_position().width  # the axes' width in inches
    edges = [lo * fps, *bounds, hi * fps]
    for i, text in enumerate(texts):
        a, b = max(edges[i] / fps, lo), min(edges[i + 1] / fps, hi)
        chars = max(8, int((b - a) / (hi - lo) * fig_w * 72 / (0.55 * fontsize)) - 1)
        top.text(
            (a + b) / 2,
            1.02,
            textwrap.fill(f"{i + 1}: {text}", chars),
            transform=top.get_xaxis_transform(),
            ha="center",
            va="bottom",
            fontsize=fontsize,
            gid="segment",
        )
