"""Diagrams of M2D2M's discrete diffusion (chapters 07-08): mask-and-replace on a token sequence, the block structure
of one transition matrix Q_t, and where the dynamic transition probability β(t, d) sends a replaced token.

Every number drawn comes from the library's own schedule and transition code (:mod:`motionlab.diffusion.schedule`,
:mod:`motionlab.diffusion.transitions`), so a diagram changes when the method does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle

from motionlab.diffusion.schedule import Schedule, get_schedule
from motionlab.diffusion.transitions import codebook_distance, dynamic_matrix, uniform_matrix

from ._draw import PALETTE, Canvas

WIDTH_IN = 7.4  # the page's column: wider figures are shrunk

# The three fates of a token: blue, orange and a mask colour, as in chapter 07's plots of the forward process
FATES = {"kept": "data", "replaced": "token", "masked": "noise"}
MASK_LABEL = "M"


def _schedule(schedule: Schedule | None) -> Schedule:
    if schedule is None:
        return get_schedule()
    if not isinstance(schedule, Schedule):
        raise ValueError(f"schedule must be a motionlab.diffusion.Schedule or None, got {type(schedule).__name__}")
    return schedule


def _step(schedule: Schedule, t: int | None, default: int) -> int:
    t = default if t is None else t
    if not isinstance(t, (int, np.integer)) or not 1 <= t <= schedule.T:
        raise ValueError(f"t must be an int in [1, T={schedule.T}], got {t!r}")
    return int(t)


def fate_counts(schedule: Schedule, t: int, num_tokens: int) -> dict[str, int]:
    """How many of ``num_tokens`` tokens are kept, replaced and masked at step ``t`` in expectation, rounded:
    ``ᾱ_t``, ``K·β̄_t`` and ``γ̄_t`` of ``schedule`` times the sequence length (the counts sum to ``num_tokens``)."""
    if not isinstance(num_tokens, int) or num_tokens < 1:
        raise ValueError(f"num_tokens must be a positive int, got {num_tokens!r}")
    changed = round(num_tokens * (1.0 - float(schedule.alpha_bar[t])))
    masked = min(round(num_tokens * float(schedule.gamma_bar[t])), changed)
    return {"kept": num_tokens - changed, "replaced": changed - masked, "masked": masked}


def mask_and_replace(
    schedule: Schedule | None = None,
    t: int | None = None,
    *,
    num_tokens: int = 12,
    num_codes: int = 512,
    seed: int = 0,
) -> Figure:
    """A token sequence at t = 0, at step ``t`` and at t = T under mask-and-replace.

    Each token is kept (probability ᾱ_t), replaced by another code (K·β̄_t) or masked (γ̄_t); the mask is absorbing.
    The three probabilities printed beside each row are ``schedule``'s (default: the book's, T = 100); the numbers
    of kept, replaced and masked tokens drawn are those probabilities times ``num_tokens``, rounded
    (:func:`fate_counts`), laid out so that every token's history is a possible path of the chain: a masked token
    stays masked, a replaced one is never restored. Codes are drawn from ``num_codes`` with ``seed``.
    """
    schedule = _schedule(schedule)
    T = schedule.T
    t = _step(schedule, t, max(1, (6 * T) // 10))
    if t == T:
        raise ValueError(f"t must lie before T={T} (the last row is t = T), got {t}")
    if not isinstance(num_codes, int) or num_codes < 2:
        raise ValueError(f"num_codes must be an int >= 2, got {num_codes!r}")
    counts = {step: fate_counts(schedule, step, num_tokens) for step in (t, T)}
    g = torch.Generator().manual_seed(seed)
    x0 = torch.randint(0, num_codes, (num_tokens,), generator=g)
    order = torch.randperm(num_tokens, generator=g)  # the order in which tokens leave their code, first to last
    other = (x0 + torch.randint(1, num_codes, (num_tokens,), generator=g)) % num_codes  # a code other than x_0

    def row(step: int) -> tuple[list[str], list[str]]:
        c = counts[step]
        fate = ["kept"] * num_tokens
        for rank, pos in enumerate(order.tolist()):
            if rank < c["masked"]:
                fate[pos] = "masked"
            elif rank < c["masked"] + c["replaced"]:
                fate[pos] = "replaced"
        labels = []
        for pos, f in enumerate(fate):
            if f == "masked":
                labels.append(MASK_LABEL)
            elif f == "replaced":  # another code, drawn uniformly (the same draw at every step it stays replaced)
                labels.append(str(int(other[pos])))
            else:
                labels.append(str(int(x0[pos])))
        return labels, [FATES[f] for f in fate]

    cell = 0.46
    left, strip_x = 0.1, 1.75
    width = strip_x + num_tokens * cell + 3.1
    canvas = Canvas(width, 4.25, inches_per_unit=min(WIDTH_IN / width, 0.75))
    rows = [
        (0, [str(int(v)) for v in x0], [FATES["kept"]] * num_tokens),
        (t, *row(t)),
        (T, *row(T)),
    ]
    ys = [3.35, 2.05, 0.75]
    for (step, labels, kinds), y in zip(rows, ys, strict=True):
        name = "$x_0$ (data)" if step == 0 else (f"$x_{{{step}}}$" if step < T else f"$x_{{T}}$, T = {T}")
        canvas.text(left, y + cell / 2, name, ha="left", fontsize=9)
        canvas.strip(strip_x, y, labels, cell=cell, kinds=kinds, fontsize=7)
        if step:
            sub = "T" if step == T else str(step)
            probs = (
                f"kept $\\bar\\alpha_{{{sub}}}$ = {float(schedule.alpha_bar[step]):.2f}\n"
                f"replaced $K\\bar\\beta_{{{sub}}}$ = {float(schedule.kbeta_bar[step]):.2f}\n"
                f"masked $\\bar\\gamma_{{{sub}}}$ = {float(schedule.gamma_bar[step]):.2f}"
            )
            canvas.text(strip_x + num_tokens * cell + 0.2, y + cell / 2, probs, ha="left", fontsize=7.5)
    mid = strip_x + num_tokens * cell / 2
    for (a, b), label in zip(((ys[0], ys[1]), (ys[1], ys[2])), (f"$t$ = 1 … {t}", f"$t$ = {t + 1} … {T}")):
        canvas.arrow(
            (mid, a - 0.05),
            (mid, b + cell + 0.05),
            f"{label}: $x_t \\sim Q_t[x_{{t-1}}, \\cdot\\,]$",
            text_offset=(2.0, -0.1),
        )
    canvas.ax.legend(
        handles=[
            Patch(facecolor=PALETTE[FATES["kept"]], edgecolor=PALETTE["edge"], label="kept: its own code"),
            Patch(facecolor=PALETTE[FATES["replaced"]], edgecolor=PALETTE["edge"], label="replaced: another code"),
            Patch(facecolor=PALETTE[FATES["masked"]], edgecolor=PALETTE["edge"], label=f"masked ({MASK_LABEL})"),
        ],
        loc="lower center",
        bbox_to_anchor=(0.5, -0.02),
        ncol=3,
        fontsize=7.5,
        frameon=False,
    )
    return canvas.finish()


def _beta_shares(schedule: Schedule, t: int, distance: torch.Tensor, eta: float, code: int = 0) -> np.ndarray:
    """β(t, d_{code, j}) for every code j, from the library's dynamic Q_t (α_t taken off the code itself)."""
    Q = dynamic_matrix(schedule, t, distance, eta)
    K = distance.shape[0]
    share = Q[code, :K].clone()
    share[code] -= schedule.alpha[t]
    return share.numpy()


def transition_matrix(
    schedule: Schedule | None = None,
    t: int | None = None,
    *,
    num_codes: int = 4,
    codebook: torch.Tensor | None = None,
    eta: float = 0.0,
) -> Figure:
    """The (K+1) × (K+1) one-step matrix Q_t at a small K as a heat map, its blocks labelled.

    Row = from (x_{t-1}), column = to (x_t). Codes keep themselves with α_t + β_t (the diagonal), move to another
    code with β_t, and become the mask with γ_t (the last column); the mask row is (0, …, 0, 1): the mask is
    absorbing. Computed by :func:`motionlab.diffusion.transitions.uniform_matrix` from ``schedule`` (default: the
    book's) at step ``t`` (default T/2); with a (K, D) ``codebook`` and ``eta`` it is M2D2M's dynamic Q_t
    (:func:`~motionlab.diffusion.transitions.dynamic_matrix`, L2-rank distances), whose off-diagonal entries differ.
    """
    schedule = _schedule(schedule)
    t = _step(schedule, t, max(1, schedule.T // 2))
    if codebook is None:
        if eta != 0.0:
            raise ValueError("eta != 0 needs a codebook (dynamic transitions depend on code distances)")
        if not isinstance(num_codes, int) or not 2 <= num_codes <= 8:
            raise ValueError(f"num_codes must be an int in [2, 8] (a matrix small enough to read), got {num_codes!r}")
        Q = uniform_matrix(schedule, t, num_codes)
        off = "$\\beta_t$"
    else:
        if codebook.ndim != 2 or not 2 <= codebook.shape[0] <= 8:
            raise ValueError(f"codebook must be (K, D) with 2 <= K <= 8, got {tuple(codebook.shape)}")
        Q = dynamic_matrix(schedule, t, codebook_distance(codebook, "l2_rank"), float(eta))
        off = "$\\beta(t,d)$"
    K = Q.shape[0] - 1
    values = Q.numpy()
    shown = np.ma.masked_equal(values, 0.0)

    fig, (ax, side) = plt.subplots(1, 2, figsize=(6.6, 3.3), gridspec_kw={"width_ratios": [1.25, 1]})
    cmap = plt.get_cmap("viridis").with_extremes(bad="white")
    positive = values[values > 0]
    low = np.log10(positive.min())
    ax.imshow(shown, cmap=cmap, norm=LogNorm(vmin=positive.min() / 2, vmax=1.0))
    for i in range(K + 1):
        for j in range(K + 1):
            if i == K:
                name = "1" if j == K else "0"
            elif j == K:
                name = "$\\gamma_t$"
            elif i == j:
                name = "$\\alpha_t{+}\\beta_t$" if codebook is None else "$\\alpha_t{+}\\beta$"
            else:
                name = off
            dark = values[i, j] > 0 and np.log10(values[i, j]) > low + 0.6 * (0.0 - low)  # light fill: black text
            number = "" if i == K else f"\n{values[i, j]:.2g}"
            ax.text(j, i, name + number, ha="center", va="center", fontsize=7, color="black" if dark else "white")
            if values[i, j] == 0:
                ax.texts[-1].set_color("black")
    ticks = [str(k) for k in range(K)] + ["M"]
    ax.set_xticks(range(K + 1), ticks, fontsize=8)
    ax.set_yticks(range(K + 1), ticks, fontsize=8)
    ax.set_xlabel("to: $x_t$ (M: [MASK])", fontsize=8.5)
    ax.set_ylabel("from: $x_{t-1}$", fontsize=8.5)
    ax.grid(False)
    blocks = (
        ((-0.5, -0.5), K, K, PALETTE["edge"], f"codes → codes: $\\alpha_t I$ + {off} on every entry"),
        ((K - 0.5, -0.5), 1, K, PALETTE["accent"], "codes → mask: $\\gamma_t$ from every code"),
        ((-0.5, K - 0.5), K + 1, 1, "#0072b2", "mask → mask: 1 (absorbing)"),
    )
    for (x, y), w, h, color, _ in blocks:
        ax.add_patch(Rectangle((x, y), w, h, fill=False, edgecolor=color, linewidth=2.2, clip_on=False))
    side.axis("off")
    lines = [(text, color) for _, _, _, color, text in blocks]
    lines += [
        ("each row sums to 1:", PALETTE["edge"]),
        ("$\\alpha_t + K\\beta_t + \\gamma_t = 1$", PALETTE["edge"]),
        (f"t = {t} of T = {schedule.T}, K = {K} codes", PALETTE["edge"]),
        ("colour: probability, log scale", PALETTE["edge"]),
    ]
    for k, (text, color) in enumerate(lines):
        side.text(0.0, 0.92 - 0.14 * k, text, color=color, fontsize=8, transform=side.transAxes, va="center")
    fig.tight_layout()
    return fig


def ring_codebook(num_codes: int = 9) -> torch.Tensor:
    """(K, 2) toy codebook: code 0 at the origin, code j at radius 1.5 + j on a golden-angle spiral, so that code j
    is the j-th nearest to code 0 (its L2 rank is j)."""
    if not isinstance(num_codes, int) or num_codes < 3:
        raise ValueError(f"num_codes must be an int >= 3, got {num_codes!r}")
    j = torch.arange(num_codes, dtype=torch.float64)
    angle = j * math.pi * (3.0 - math.sqrt(5.0))
    radius = torch.where(j > 0, 1.5 + j, torch.zeros_like(j))
    return torch.stack([radius * torch.cos(angle), radius * torch.sin(angle)], dim=1)


def dynamic_beta(
    schedule: Schedule | None = None,
    *,
    eta: float = 4.0,
    etas: Sequence[float] = (0.0, 0.5, 2.0, 4.0),
    num_codes: int = 9,
    codebook: torch.Tensor | None = None,
) -> Figure:
    """Where a replaced token goes under M2D2M's β(t, d): near and far codes around the current one, at t = T.

    Left and middle: code 0 of a toy codebook (:func:`ring_codebook`) and its neighbours, each labelled with its
    rank distance d; an arrow to each code is as wide as β(T, d), uniform (η = 0, VQ-Diffusion) and dynamic (``eta``).
    Right: β(t, d) / β_t over d at t = T for each of ``etas``; 1 is the uniform share. With η > 0 (the paper's
    reading) far codes get more of the replaced mass as t grows; at t → 0 every η is uniform. Every share is read off
    the library's dynamic Q_t (:func:`~motionlab.diffusion.transitions.dynamic_matrix`) of ``schedule`` (default: the
    book's), with L2-rank distances (:func:`~motionlab.diffusion.transitions.codebook_distance`).
    """
    schedule = _schedule(schedule)
    codebook = ring_codebook(num_codes) if codebook is None else codebook
    if not isinstance(codebook, torch.Tensor) or codebook.ndim != 2 or codebook.shape[1] != 2:
        raise ValueError(
            f"codebook must be a (K, 2) tensor (drawn in the plane), got {getattr(codebook, 'shape', None)}"
        )
    if not etas or any(not math.isfinite(float(e)) for e in (*etas, eta)):
        raise ValueError(f"eta and etas must be finite numbers (etas non-empty), got {eta!r}, {etas!r}")
    K, T = codebook.shape[0], schedule.T
    ranks = codebook_distance(codebook, "l2_rank")
    uniform_share = float(schedule.kbeta[T]) / K
    points = codebook.numpy()

    fig, axes = plt.subplots(1, 3, figsize=(WIDTH_IN, 2.75), gridspec_kw={"width_ratios": [1, 1, 1.25]})
    reach = np.abs(points).max() * 1.25
    for ax, e in zip(axes[:2], (0.0, float(eta)), strict=True):
        shares = _beta_shares(schedule, T, ranks, e)
        for j in range(1, K):
            width = min(1.2 * shares[j] / uniform_share, 6.0)  # 1.2 pt: the uniform share β_T
            ax.annotate(
                "",
                xy=points[j],
                xytext=points[0],
                arrowprops=dict(arrowstyle="-|>", lw=max(width, 0.2), color=PALETTE["accent"], shrinkA=6, shrinkB=7),
            )
        near = ranks[0].numpy()
        ax.scatter(points[1:, 0], points[1:, 1], s=150, c=PALETTE["token"], edgecolors=PALETTE["edge"], zorder=3)
        ax.scatter(*points[0], s=220, c=PALETTE["data"], edgecolors=PALETTE["edge"], zorder=3)
        ax.text(*points[0], "i", ha="center", va="center", fontsize=8, zorder=4)
        for j in range(1, K):
            ax.text(*points[j], f"{int(near[j])}", ha="center", va="center", fontsize=7, zorder=4)
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-reach, reach)
        ax.set_aspect("equal")
        ax.axis("off")
        title = "uniform: η = 0" if e == 0.0 else f"dynamic: η = {e:g}"
        ax.set_title(f"{title}, t = T\n(arrow width ∝ β(T, d))", fontsize=8.5)
        ax.text(0.0, -reach * 0.98, "numbers: rank distance d from i", ha="center", va="bottom", fontsize=7)
    d = np.arange(K)
    order = np.argsort(ranks[0].numpy())
    for e in etas:
        relative = _beta_shares(schedule, T, ranks, float(e))[order] / uniform_share
        axes[2].plot(d, relative, "o-", markersize=3, label=f"η = {float(e):g}")
    axes[2].axhline(1.0, color="grey", lw=0.8, ls="--")
    axes[2].set_xlabel("rank distance d from code i", fontsize=8)
    axes[2].set_ylabel("$\\beta(T, d)\\,/\\,\\beta_T$", fontsize=8)
    axes[2].set_xticks(d)
    axes[2].tick_params(labelsize=7)
    axes[2].set_title("share of the replaced mass\nnear codes (left) to far (right)", fontsize=8.5)
    axes[2].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    fig.tight_layout(w_pad=0.4)
    return fig
