"""Diagrams of the flow part of the book: rectified-flow paths (chapter 03), DisCoRD's condition projection
(chapter 04) and sJPE's two halves (chapter 06).

Every quantity drawn is computed by the library's own concept code: the straight paths by
:func:`motionlab.flow.interpolate`, the ODE paths and the single steps by the steppers of
:mod:`motionlab.flow.rectified_flow` (through :func:`motionlab.flow.toy.flow_trajectory`), the frame features by
the projections of :mod:`motionlab.flow.condition`, jerk by :func:`motionlab.metrics.finite_difference_jerk` and
sJPE's elements by :func:`motionlab.metrics.sjpe.sjpe_elements`.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from torch import Tensor

from motionlab.flow import interpolate, make_condition_projection, sample_noise
from motionlab.flow.rectified_flow import euler_step, midpoint_step
from motionlab.flow.toy import flow_trajectory, sample_toy, straightness
from motionlab.metrics import finite_difference_jerk
from motionlab.metrics.perturbations import smooth_in_time
from motionlab.metrics.sjpe import sjpe_elements

from ._draw import PALETTE, Canvas

MAX_WIDTH = 7.4  # inches: a figure wider than the page column is shrunk

_CLUSTER_COLOURS = plt.get_cmap("tab10")


def _positive_int(name: str, value: object, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}, got {value!r}")
    return value


# ----------------------------------------------------------------------------- chapter 03: straight and curved paths


class RingField:
    """The exact velocity field ``v*(x, t) = E[x1 − x0 | x_t = x]`` of the toy ring, a mixture of Gaussians.

    The ring's centres ``μ_k`` and spread ``s`` are measured on ``n`` points of :func:`~motionlab.flow.toy.sample_toy`
    (not retyped). Given cluster ``k``, ``x_t = t·x1 + (1 − t)·x0`` is Gaussian with mean ``t·μ_k`` and variance
    ``t²s² + (1 − t)²`` per axis, so ``E[x1 − x0 | x_t = x, k] = μ_k + (t·s² − (1 − t)) / var_t · (x − t·μ_k)``; without
    the cluster, the clusters' fields are averaged with their posterior weights at ``x``. Called with ``cond`` = cluster
    ids it is the *conditional* field (a class label, as in the chapter's conditional toy).
    """

    def __init__(self, n: int = 8000, seed: int = 0) -> None:
        points, labels = sample_toy("ring", _positive_int("n", n, 100), torch.Generator().manual_seed(seed))
        ids = labels.unique()
        self.centres = torch.stack([points[labels == k].mean(0) for k in ids]).double()  # (K, 2)
        self.weights = torch.stack([(labels == k).double().mean() for k in ids])  # (K,)
        self.spread = (points.double() - self.centres[labels]).std().item()  # s, per axis

    def per_cluster(self, x: Tensor, t: Tensor) -> tuple[Tensor, Tensor]:
        """Each cluster's velocity ``(B, K, 2)`` and its log posterior weight ``(B, K)`` at points ``x`` ``(B, 2)``."""
        x, t = x.double(), t.double()[:, None, None]  # (B, 2), (B, 1, 1)
        var = t**2 * self.spread**2 + (1 - t) ** 2  # (B, 1, 1)
        offset = x[:, None, :] - t * self.centres[None]  # (B, K, 2): x − t·μ_k
        velocity = self.centres[None] + (t * self.spread**2 - (1 - t)) / var * offset
        log_weight = self.weights.log()[None] - (offset**2).sum(-1) / (2 * var[..., 0]) - torch.log(var[..., 0])
        return velocity, log_weight

    def __call__(self, x: Tensor, t: Tensor, cond: Tensor | None = None) -> Tensor:
        velocity, log_weight = self.per_cluster(x, t)
        if cond is not None:
            return velocity[torch.arange(len(x)), cond].to(x.dtype)  # (B, 2): the cluster's own field
        posterior = torch.softmax(log_weight, dim=1)  # (B, K)
        return (posterior[..., None] * velocity).sum(1).to(x.dtype)  # (B, 2)


def rectified_paths(n_paths: int = 24, step: float = 0.5, seed: int = 0) -> Figure:
    """Chapter 03's opening picture, four panels on the toy ring of eight Gaussians.

    (a) ``n_paths`` independent pairs ``(x0, x1)`` joined by the straight lines of :func:`~motionlab.flow.interpolate`:
    they cross. (b) The ODE paths of the exact field ``E[x1 − x0 | x_t]`` (:class:`RingField`) from the same noise:
    they cannot cross, so they bend, first towards the data mean. (c) The same with the cluster as a condition:
    nearly straight. (d) One step of size ``step`` on the most curved path of (b): Euler follows the slope at the
    start and leaves the path; midpoint re-reads the slope half-way and lands near it.
    """
    _positive_int("n_paths", n_paths, 2)
    if not 0 < step <= 1:
        raise ValueError(f"step must be in (0, 1], got {step!r}")
    g = torch.Generator().manual_seed(seed)
    field = RingField(seed=seed)
    x1, labels = sample_toy("ring", n_paths, g)
    x0 = sample_noise((n_paths, 2), g)
    ts = torch.linspace(0, 1, 2)
    lines = torch.stack([interpolate(x0, x1, torch.full((n_paths,), float(t))) for t in ts])  # (2, B, 2)
    curved = flow_trajectory(field, x0, 64, "midpoint")  # (65, B, 2)
    straight = flow_trajectory(field, x0, 64, "midpoint", labels)

    fig, axes = plt.subplots(1, 4, figsize=(MAX_WIDTH, 2.7))
    titles = [
        "(a) training pairs:\nstraight lines that cross",
        "(b) ODE paths, no condition:\ncurved, never crossing",
        "(c) ODE paths given the cluster:\nnearly straight",
        f"(d) one step of size {step:g} on\nthe most curved path of (b)",
    ]
    for ax, title in zip(axes, titles):
        ax.set_title(title, fontsize=8)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    colours = [_CLUSTER_COLOURS(int(k) % 10) for k in labels]
    for i in range(n_paths):
        axes[0].plot(lines[:, i, 0], lines[:, i, 1], color=colours[i], lw=0.8)
        axes[1].plot(curved[:, i, 0], curved[:, i, 1], color=PALETTE["edge"], lw=0.8)
        axes[2].plot(straight[:, i, 0], straight[:, i, 1], color=colours[i], lw=0.8)
    for ax, ends in zip(axes[:3], (x1, curved[-1], straight[-1])):
        ax.scatter(x0[:, 0], x0[:, 1], s=6, color="k", zorder=3)
        ax.scatter(ends[:, 0], ends[:, 1], s=6, color=PALETTE["accent"], zorder=3)
        ax.set_xlim(-3.2, 3.2)
        ax.set_ylim(-3.2, 3.2)

    # (d): the most curved path of (b) against t, projected on the direction u of its end point, and one Euler and
    # one midpoint step from its start (a projection is linear, so the steps' slopes project as they are)
    i = int(straightness(curved).argmin())
    start = x0[i : i + 1]
    fine = flow_trajectory(field, start, 256, "midpoint")[:, 0]  # (257, 2): the path, resolved finely
    u = fine[-1] / fine[-1].norm()

    def along(x: Tensor) -> float:
        return float(x.reshape(-1) @ u)

    euler = euler_step(field, start, 0.0, step)
    half = euler_step(field, start, 0.0, step / 2)  # the midpoint rule's probe: half an Euler step
    midpoint = midpoint_step(field, start, 0.0, step)
    ax = axes[3]
    ax.set_aspect("auto")
    ax.set_xticks([0, step, 1])
    ax.tick_params(labelsize=7)
    ax.set_xlabel("flow time t", fontsize=7, labelpad=1)
    ax.set_ylabel("position along u", fontsize=7, labelpad=1)
    ax.plot(torch.linspace(0, 1, len(fine)), fine @ u, color="#999999", lw=1.5)
    a, r_half = (0.0, along(start)), (step / 2, along(half))
    ax.annotate("", (step, along(euler)), a, arrowprops={"arrowstyle": "-|>", "color": PALETTE["accent"], "lw": 1.2})
    ax.plot([a[0], r_half[0]], [a[1], r_half[1]], color="#0072b2", lw=0.9, ls=":")
    rise = (along(midpoint) - a[1]) / 2  # the slope read at the probe, over half a step
    ax.annotate(
        "",
        (r_half[0] + step / 2, r_half[1] + rise),
        r_half,
        arrowprops={"arrowstyle": "-|>", "color": "#0072b2", "lw": 0.9, "ls": ":"},
    )
    ax.annotate("", (step, along(midpoint)), a, arrowprops={"arrowstyle": "-|>", "color": "#0072b2", "lw": 1.2})
    ax.scatter(*a, s=14, color="k", zorder=3)
    ax.scatter(step, float(fine[round(256 * step)] @ u), s=30, facecolor="none", edgecolor="k", zorder=3)
    ax.scatter(*r_half, s=10, color="#0072b2", zorder=3)
    heights = [*(fine @ u).tolist(), along(euler), along(midpoint), r_half[1], r_half[1] + rise]
    margin = 0.08 * (max(heights) - min(heights))
    ax.set_ylim(min(heights) - margin, max(heights) + margin)
    ax.set_xlim(-0.05, 1.05)
    ax.set_yticks([])
    ax.set_box_aspect(1)

    handles = [
        Line2D([], [], marker="o", ls="", color="k", ms=3, label="noise $x_0$"),
        Line2D([], [], marker="o", ls="", color=PALETTE["accent"], ms=3, label="data $x_1$ / path end"),
        Line2D([], [], color="#999999", lw=1.5, label="exact path"),
        Line2D([], [], marker="o", ls="", mfc="none", mec="k", ms=5, label=f"exact point at t = {step:g}"),
        Line2D([], [], color=PALETTE["accent"], lw=1.2, label="Euler step"),
        Line2D([], [], color="#0072b2", lw=0.9, ls=":", label="midpoint: slope re-read half-way"),
        Line2D([], [], color="#0072b2", lw=1.2, label="midpoint step"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=7, frameon=False, bbox_to_anchor=(0.5, 0.0))
    fig.tight_layout(rect=(0, 0.17, 1, 1), w_pad=0.6)
    return fig


# ----------------------------------------------------------------------------- chapter 04: condition projection


def _feature_columns(
    canvas: Canvas, x: float, y: float, features: np.ndarray, cell: float, scale: float, q: int
) -> None:
    """Frame features ``(T, d_feat)`` as ``T`` columns of ``d_feat`` coloured squares (blue negative, red
    positive), with a thick line at every token boundary (every ``q`` frames)."""
    n_frames, width = features.shape
    canvas.ax.imshow(
        features.T[::-1],
        cmap="RdBu_r",
        vmin=-scale,
        vmax=scale,
        extent=(x, x + n_frames * cell, y, y + width * cell * 0.5),
        interpolation="nearest",
        zorder=2,
    )
    for f in range(n_frames + 1):
        lw = 1.2 if f % q == 0 else 0.3
        canvas.ax.plot([x + f * cell] * 2, [y, y + width * cell * 0.5], color=PALETTE["edge"], lw=lw, zorder=3)
    canvas.ax.plot([x, x + n_frames * cell], [y, y], color=PALETTE["edge"], lw=0.8, zorder=3)
    canvas.ax.plot([x, x + n_frames * cell], [y + width * cell * 0.5] * 2, color=PALETTE["edge"], lw=0.8, zorder=3)


def projection_features(q: int = 4, n_tokens: int = 3, code_dim: int = 6, cond_dim: int = 6, seed: int = 0):
    """The frame features ``(q·N, d_feat)`` that DisCoRD's projection and plain repetition give ``n_tokens`` random code
    vectors, each from :func:`~motionlab.flow.make_condition_projection` with weights initialised from ``seed``:
    ``{"stacked": ..., "repeat": ...}``."""
    for name, value in (("q", q), ("n_tokens", n_tokens), ("code_dim", code_dim), ("cond_dim", cond_dim)):
        _positive_int(name, value)
    z = torch.randn(1, n_tokens, code_dim, generator=torch.Generator().manual_seed(seed))  # (1, N, d)
    out = {}
    for kind in ("stacked", "repeat"):
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            projection = make_condition_projection(kind, code_dim, cond_dim, q=q)
        with torch.no_grad():
            out[kind] = projection(z)[0].numpy()  # (q·N, d_feat)
    return out


def condition_projection(q: int = 4, n_tokens: int = 3, cond_dim: int = 6, seed: int = 0) -> Figure:
    """Chapter 04's opening picture: DisCoRD's condition projection beside plain repetition.

    Left, top to bottom: the code vectors ``Z`` (``T/q × d``), each repeated ``q`` times, the ``q`` copies of a
    token stacked into one vector of ``q·d``, one linear layer ``W`` (``q·d × q·d``, shared by all tokens), unstacked
    into ``q`` frame vectors, and a per-frame linear layer to the conditions ``C`` (``T × d_feat``). Right: repeat
    then a per-frame linear layer, whose ``q`` frames of one token are identical. The coloured columns are the
    features the library's two projections (:func:`projection_features`) compute for random code vectors.
    """
    _positive_int("q", q, 2)
    _positive_int("n_tokens", n_tokens)
    _positive_int("cond_dim", cond_dim)
    if q * n_tokens > 16:
        raise ValueError(f"q · n_tokens must be at most 16 frames to fit the page, got {q * n_tokens}")
    features = projection_features(q, n_tokens, code_dim=cond_dim, cond_dim=cond_dim, seed=seed)
    scale = max(np.abs(f).max() for f in features.values())
    n_frames = q * n_tokens
    cell = 3.6 / n_frames
    heat = cond_dim * cell * 0.5  # height of the feature columns
    canvas = Canvas(10.0, 6.9, inches_per_unit=0.74)

    def token_row(x: float, y: float) -> None:
        for n in range(n_tokens):
            canvas.box(x + n * q * cell, y, q * cell, cell, f"$z_{n + 1}$", "token", fontsize=8, rounded=False)

    def repeated(x: float, y: float) -> None:
        canvas.strip(x, y, [f"$z_{f // q + 1}$" for f in range(n_frames)], cell=cell, fontsize=6)

    def step(x: float, y_from: float, y_to: float, text: str) -> None:
        canvas.arrow((x, y_from), (x, y_to))
        canvas.text(x + 0.12, (y_from + y_to) / 2, text, fontsize=7, ha="left")

    def shape(x: float, y: float, text: str) -> None:
        canvas.text(x + n_frames * cell + 0.1, y, text, fontsize=7, ha="left")

    # left: DisCoRD
    x0, ys = 0.3, [6.0, 5.2, 4.4, 3.6, 2.8, 0.75]
    mid = x0 + n_frames * cell / 2
    canvas.text(mid + 0.6, 6.75, "DisCoRD: repeat → stack → linear → unstack", fontsize=9, weight="bold")
    token_row(x0, ys[0])
    shape(x0, ys[0] + cell / 2, "$Z$: $T/q × d$")
    step(mid, ys[0], ys[1] + cell, f"repeat each token q = {q} times")
    repeated(x0, ys[1])
    step(mid, ys[1], ys[2] + cell, "stack the q copies of a token")
    copies = "$[" + "; ".join(["z"] * q) + "]$"
    for n in range(n_tokens):
        canvas.box(x0 + n * q * cell + 0.04, ys[2], q * cell - 0.08, cell, copies, "token", fontsize=6)
    shape(x0, ys[2] + cell / 2, "$T/q × qd$")
    step(mid, ys[2], ys[3] + cell, "one linear layer W: qd → qd")
    for n in range(n_tokens):
        canvas.box(x0 + n * q * cell + 0.04, ys[3], q * cell - 0.08, cell, "$W[\\cdot] + b$", "network", fontsize=6)
    shape(x0, ys[3] + cell / 2, "same W for every token")
    step(mid, ys[3], ys[4] + cell, "unstack: q different frame vectors")
    canvas.strip(x0, ys[4], [f"$u_{{{f + 1}}}$" for f in range(n_frames)], cell=cell, kinds="operation", fontsize=6)
    step(mid, ys[4], ys[5] + heat, "per-frame linear: $d → d_{feat}$")
    _feature_columns(canvas, x0, ys[5], features["stacked"], cell, scale, q)
    shape(x0, ys[5] + heat / 2, "$C$: $T × d_{feat}$")
    canvas.bracket(x0, x0 + q * cell, ys[5] - 0.05, "one token: q distinct frames", fontsize=7)

    # right: plain repetition
    x1 = 6.2
    mid = x1 + n_frames * cell / 2
    canvas.text(mid, 6.75, "plain repetition", fontsize=9, weight="bold")
    token_row(x1, ys[0])
    step(mid, ys[0], ys[1] + cell, "repeat q times")
    repeated(x1, ys[1])
    feats_y = ys[3] - 0.2
    step(mid, ys[1], feats_y + heat, "per-frame linear: $d → d_{feat}$")
    _feature_columns(canvas, x1, feats_y, features["repeat"], cell, scale, q)
    canvas.bracket(x1, x1 + q * cell, feats_y - 0.05, "one token: q equal frames", fontsize=7)
    canvas.text(
        x1,
        1.55,
        "$c_{qn+i} = A\\,z_n + a$,  $i = 0, \\dots, q-1$:\n"
        "no $i$ on the right, so the q frames of a\n"
        "token get the same condition, and the\n"
        "decoder cannot tell where in its token\n"
        "a frame sits",
        fontsize=7,
        ha="left",
        va="center",
        color=PALETTE["accent"],
    )
    return canvas.finish()


# ----------------------------------------------------------------------------- chapter 06: sJPE's two halves


def example_jerk(n_frames: int = 80, fps: float = 20.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A made-up pair of one joint's height over time, ``(T, 1)`` each in metres: the ground truth sways slowly
    (1 Hz, 2 cm), rises 30 cm with a minimum-jerk profile and drops back quickly; the prediction adds 1 mm of
    jitter to the first half and blurs the second (a Gaussian of 2 frames,
    :func:`~motionlab.metrics.perturbations.smooth_in_time`)."""
    _positive_int("n_frames", n_frames, 40)
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps!r}")

    def minimum_jerk(a: int, b: int, height: float) -> np.ndarray:
        s = np.clip((np.arange(n_frames) - a) / (b - a), 0, 1)
        return height * (10 * s**3 - 15 * s**4 + 6 * s**5)

    t = n_frames
    sway = 0.02 * np.sin(2 * np.pi * 1.0 * np.arange(t) / fps)  # a slow 1 Hz sway: real motion is never still
    truth = sway + minimum_jerk(t // 10, t * 4 // 10, 0.3) - minimum_jerk(t * 6 // 10, t * 6 // 10 + 8, 0.3)
    truth = truth[:, None]  # (T, 1)
    jitter = np.random.default_rng(seed).normal(0.0, 0.001, truth.shape) * (np.arange(t) < t // 2)[:, None]
    blurred = smooth_in_time([truth], 2.0)[0]
    prediction = np.where(np.arange(t)[:, None] < t // 2, truth + jitter, blurred)
    return prediction, truth


def sjpe_halves(fps: float = 20.0, seed: int = 0) -> Figure:
    """Chapter 06's opening picture: sJPE compares two jerk curves frame by frame.

    Top: the jerk magnitude of a prediction and of its ground truth (:func:`example_jerk`, one joint), shaded where
    the prediction has more (Noise: jerk added) and less (Static: jerk missed). Bottom: each frame's element
    ``|J_pred − J_true| / (J_pred + J_true)`` from :func:`~motionlab.metrics.sjpe.sjpe_elements`, up for Noise, down for
    Static; their means over the frames are the clip's Noise and Static sJPE for this joint.
    """
    prediction, truth = example_jerk(fps=fps, seed=seed)
    jp = np.abs(finite_difference_jerk(prediction, fps, axis=0))  # (T − 3, 1)
    jt = np.abs(finite_difference_jerk(truth, fps, axis=0))
    noise, static = sjpe_elements(jp, jt)  # (T − 3, 1) each
    time = (np.arange(len(jp)) + 1.5) / fps  # a third difference sits between frames t and t + 3
    jp, jt, noise, static = jp[:, 0], jt[:, 0], noise[:, 0], static[:, 0]

    blue, red = "#0072b2", PALETTE["accent"]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(MAX_WIDTH, 3.6), sharex=True, height_ratios=[1.3, 1])
    top.plot(time, jt, color="k", lw=1.2, label="$J_{\\mathrm{true}}$: ground truth")
    top.plot(time, jp, color="#7b3294", lw=1.0, label="$J_{\\mathrm{pred}}$: prediction")
    top.fill_between(time, jt, jp, where=jp > jt, color=blue, alpha=0.35, lw=0, label="Noise: jerk added")
    top.fill_between(time, jt, jp, where=jp < jt, color=red, alpha=0.35, lw=0, label="Static: jerk missed")
    top.set_ylabel("|jerk| (m/s³)", fontsize=8)
    top.set_title("jitter in the first half, blur in the second", fontsize=9)
    top.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    width = 0.9 / fps
    bottom.bar(time, noise, width=width, color=blue, label=f"Noise element\n(mean {noise.mean():.2f})")
    bottom.bar(time, -static, width=width, color=red, label=f"Static element\n(mean {static.mean():.2f})")
    bottom.axhline(0, color="k", lw=0.6)
    bottom.set_ylim(-1.05, 1.05)
    bottom.set_yticks([-1, 0, 1], ["1", "0", "1"])
    bottom.set_ylabel("element\n(Static ↓, Noise ↑)", fontsize=8)
    bottom.set_xlabel("time (s)", fontsize=8)
    bottom.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    for ax in (top, bottom):
        ax.tick_params(labelsize=7)
    fig.tight_layout(h_pad=0.4)
    return fig


__all__ = [
    "RingField",
    "condition_projection",
    "example_jerk",
    "projection_features",
    "rectified_paths",
    "sjpe_halves",
]
